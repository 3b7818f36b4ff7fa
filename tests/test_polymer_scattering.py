"""Single-chain S(q) and S(q, t) against exact Gaussian-chain results and identities.

Reference: for a Gaussian chain r_i - r_j is Gaussian with <|r_i - r_j|^2> = |i-j| l^2,
so <exp(i q.(r_i - r_j))> = exp(-q^2 l^2 |i-j|/6) and the exact discrete form factor is
S(q) = (1/N) sum_ij exp(-q^2 l^2 |i-j|/6) (Doi & Edwards 1986, sec. 2.6; its continuum
limit is N times the Debye function 2(e^-x + x - 1)/x^2, x = q^2 R_g^2).  Chains are
independent, so errors are standard errors over chains of the per-chain shell averages;
each check allows 4 of them.
"""

import jax.numpy as jnp
import numpy as np
import pytest
from gaussian_chains import gaussian_chains, mean_and_error

from jaxdpd.analysis import scattering

N_CHAINS, N_BEADS = 2000, 16
BOX = np.array([20.0, 20.0, 20.0])
TOLERANCE_SIGMAS = 4.0


def exact_gaussian_form_factor(q, n_beads, bond_length_squared=1.0):
    separation = np.abs(np.arange(n_beads)[:, None] - np.arange(n_beads)[None, :])
    q = np.asarray(q)[..., None, None]
    return np.exp(-(q**2) * bond_length_squared * separation / 6).sum(axis=(-2, -1)) / n_beads


def debye(x):
    return 2 * (np.exp(-x) + x - 1) / x**2


@pytest.fixture(scope="module")
def chains():
    return jnp.asarray(gaussian_chains(seed=5, n_chains=N_CHAINS, n_beads=N_BEADS))


@pytest.fixture(scope="module")
def shells():
    return scattering.wave_vector_shells(BOX, q_max=4.0, shell_width=np.pi / 20, max_per_shell=8)


def test_wave_vector_shells_are_box_compatible(shells):
    """Every q is 2 pi n / L with integer n, |q| <= q_max, no +-q duplicates, shells ordered."""
    n = shells.vectors * BOX / (2 * np.pi)
    np.testing.assert_allclose(n, np.round(n), atol=1e-9)
    assert np.all(np.linalg.norm(shells.vectors, axis=1) <= 4.0 + 1e-9)
    keys = {tuple(v) for v in np.round(n).astype(int)}
    assert not any(tuple(-np.array(k)) in keys for k in keys)
    assert np.all(np.diff(shells.q) > 0) and np.all(shells.vectors_per_shell <= 8)
    assert 2 * np.pi / 20 <= shells.q[0] < 2 * np.pi / 20 + np.pi / 20
    with pytest.raises(ValueError, match="box_lengths"):
        scattering.wave_vector_shells([20.0, 20.0], q_max=1.0)
    with pytest.raises(ValueError, match="q_max"):
        scattering.wave_vector_shells(BOX, q_max=0.1)


def test_structure_factor_of_gaussian_chains(chains, shells):
    """Shell-averaged S(q) equals the exact discrete Gaussian form factor within errors;
    at small q it is N times the Debye function (to within the discreteness correction,
    checked to be smaller than the statistical error there); at q >> 1/l it is 1."""
    per_chain = scattering.shell_average(
        scattering.chain_structure_factor(chains, shells.vectors), shells
    )
    measured, error = mean_and_error(per_chain)
    norms = np.linalg.norm(shells.vectors, axis=1)

    def shell_mean(values):
        return np.bincount(shells.shell, weights=values) / shells.vectors_per_shell

    exact = shell_mean(exact_gaussian_form_factor(norms, N_BEADS))
    assert np.all(np.abs(measured - exact) < TOLERANCE_SIGMAS * error), (measured - exact) / error

    radius_squared = (N_BEADS**2 - 1) / (6 * N_BEADS)
    small = shells.q**2 * radius_squared < 1
    assert small.sum() >= 2
    continuum = shell_mean(N_BEADS * debye(norms**2 * radius_squared))[small]
    assert np.all(np.abs(exact[small] - continuum) < error[small])
    assert np.all(np.abs(measured[small] - continuum) < TOLERANCE_SIGMAS * error[small])

    large = scattering.wave_vector_shells(BOX, q_max=30.0, shell_width=2.0, max_per_shell=8)
    far = large.q > 25
    per_chain_large = scattering.shell_average(
        scattering.chain_structure_factor(chains, large.vectors), large
    )[:, far]
    measured_large, error_large = mean_and_error(per_chain_large)
    # Exact value: 1 + 2/N sum_k (N-k) exp(-q^2 k/6) = 1 + O(1e-45) at q > 25.
    assert np.all(np.abs(measured_large - 1) < TOLERANCE_SIGMAS * error_large)


def test_intermediate_scattering_identities(chains, shells):
    """S(q, 0) = S(q) exactly, and a rigid translation d gives S(q, t) = cos(q.d) S(q)
    (rho_q picks up the phase exp(i q.d); Ahlrichs & Dünweg eq. 40)."""
    static = scattering.chain_structure_factor(chains[:100], shells.vectors)
    same = scattering.chain_intermediate_scattering(chains[:100], chains[:100], shells.vectors)
    np.testing.assert_allclose(same, static, rtol=1e-10, atol=1e-10)
    shift = jnp.asarray([0.3, -1.1, 2.5])
    moved = scattering.chain_intermediate_scattering(
        chains[:100], chains[:100] + shift, shells.vectors
    )
    expected = np.cos(shells.vectors @ np.asarray(shift)) * np.asarray(static)
    np.testing.assert_allclose(moved, expected, rtol=1e-9, atol=1e-9)
    single32 = scattering.chain_structure_factor(chains[:10].astype(jnp.float32), shells.vectors)
    assert single32.dtype == jnp.float32
    np.testing.assert_allclose(single32, static[:10], rtol=2e-4, atol=2e-4)
    with pytest.raises(ValueError, match="same shape"):
        scattering.chain_intermediate_scattering(chains[:2], chains[:3], shells.vectors)
    with pytest.raises(ValueError, match="wave_vectors"):
        scattering.chain_structure_factor(chains, np.zeros((4, 2)))
