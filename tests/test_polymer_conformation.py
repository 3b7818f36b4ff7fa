"""Chain conformation observables against exact ideal-chain (Gaussian random-walk) results.

2000 independent Gaussian chains of N = 16 beads with <|b|^2> = 1 are drawn exactly with
NumPy (tests/gaussian_chains.py); chains are independent, so the standard error of a
chain average is std/sqrt(n_chains), and each check allows 4 standard errors.
"""

import jax
import jax.numpy as jnp
import numpy as np
import pytest
from gaussian_chains import gaussian_chains, mean_and_error

from jaxdpd.analysis import conformation as conf

N_CHAINS, N_BEADS = 2000, 16
TOLERANCE_SIGMAS = 4.0


@pytest.fixture(scope="module")
def chains():
    return gaussian_chains(seed=11, n_chains=N_CHAINS, n_beads=N_BEADS)


def test_rouse_modes_of_ideal_chains_are_uncorrelated_with_rouse_amplitudes(chains):
    """<X_p . X_q> = delta_pq l^2 / (8 N sin^2(p pi/2N)) for p, q >= 1 (derivation in
    gaussian_chain_rouse_amplitudes; modes as Ahlrichs & Dünweg 1999 eq. 37).

    For an ideal chain the X_p are Gaussian vectors, independent for p != q, with
    independent components of variance a_p/3 (a_p = <X_p^2>).  Hence for the chain
    average over M chains:
      off-diagonal: var(X_p . X_q) = 3 (a_p/3)(a_q/3) = a_p a_q / 3,
                    standard error sqrt(a_p a_q / (3M));
      diagonal:     X_p^2 = (a_p/3) chi^2_3, var = 2 a_p^2 / 3,
                    standard error a_p sqrt(2/(3M)).
    """
    modes = np.asarray(conf.rouse_modes(jnp.asarray(chains)))[:, 1:]  # p = 1 .. N-1
    products = np.einsum("cpd,cqd->pq", modes, modes) / N_CHAINS
    amplitude = conf.gaussian_chain_rouse_amplitudes(N_BEADS)

    diagonal_error = amplitude * np.sqrt(2 / (3 * N_CHAINS))
    z_diagonal = (np.diag(products) - amplitude) / diagonal_error
    assert np.all(np.abs(z_diagonal) < TOLERANCE_SIGMAS), z_diagonal

    off = ~np.eye(N_BEADS - 1, dtype=bool)
    off_error = np.sqrt(np.outer(amplitude, amplitude) / (3 * N_CHAINS))
    z_off = (products / off_error)[off]
    assert np.all(np.abs(z_off) < 4.5), np.abs(z_off).max()
    # The 105 distinct z (each pair appears twice) are ~ N(0, 1): their mean square is
    # 1 within sqrt(2/105) = 0.14; 4 of those standard deviations are allowed.
    pairs = z_off.size // 2
    assert abs(np.mean(z_off**2) - 1) < TOLERANCE_SIGMAS * np.sqrt(2 / pairs)


def test_rouse_modes_invert_and_normalisations_agree(chains):
    """r_n = X_0 + 2 sum_{p>=1} X_p cos(p pi (n - 1/2)/N) (discrete cosine inverse), X_0 is
    the centre of mass, and Mussawisade et al. eq. 18 modes are sqrt(2N) X_p."""
    x = jnp.asarray(chains[:50])
    modes = np.asarray(conf.rouse_modes(x))
    p = np.arange(1, N_BEADS)[:, None]
    n = np.arange(1, N_BEADS + 1)[None, :]
    basis = np.cos(p * np.pi * (n - 0.5) / N_BEADS)
    rebuilt = modes[:, :1] + 2 * np.einsum("pn,cpd->cnd", basis, modes[:, 1:])
    np.testing.assert_allclose(rebuilt, chains[:50], rtol=0, atol=1e-12)
    np.testing.assert_allclose(modes[:, 0], np.asarray(conf.center_of_mass(x)), atol=1e-12)
    orthonormal = np.asarray(conf.rouse_modes(x, normalization="orthonormal"))
    np.testing.assert_allclose(orthonormal[:, 1:], np.sqrt(2 * N_BEADS) * modes[:, 1:], atol=1e-12)
    np.testing.assert_allclose(
        conf.gaussian_chain_rouse_amplitudes(N_BEADS, normalization="orthonormal"),
        2 * N_BEADS * conf.gaussian_chain_rouse_amplitudes(N_BEADS),
    )


def test_gyration_and_end_to_end_of_gaussian_chains(chains):
    """<R_g^2> = l^2 (N^2 - 1)/(6N) and <R_e^2> = (N - 1) l^2 for the discrete Gaussian
    chain (Doi & Edwards 1986, eqs. 2.52 and 2.5)."""
    x = jnp.asarray(chains)
    rg2_mean, rg2_error = mean_and_error(conf.gyration_radius_squared(x))
    assert abs(rg2_mean - (N_BEADS**2 - 1) / (6 * N_BEADS)) < TOLERANCE_SIGMAS * rg2_error
    re2_mean, re2_error = mean_and_error(conf.end_to_end_squared(x))
    assert abs(re2_mean - (N_BEADS - 1)) < TOLERANCE_SIGMAS * re2_error
    # The pair form (Ahlrichs & Dünweg eq. 21) equals the centre-of-mass form exactly.
    pair = np.sum((chains[:, :, None] - chains[:, None]) ** 2, axis=(1, 2, 3)) / (2 * N_BEADS**2)
    np.testing.assert_allclose(conf.gyration_radius_squared(x), pair, rtol=1e-12)
    # <R_e R_e> of an isotropic ensemble is (R_e^2/3) I.
    tensor = np.asarray(conf.conformation_tensor(conf.end_to_end_vector(x), axis=0))
    per_chain = np.asarray(conf.end_to_end_vector(x))
    outer = per_chain[:, :, None] * per_chain[:, None, :]
    tensor_error = outer.std(axis=0, ddof=1) / np.sqrt(N_CHAINS)
    expected = (N_BEADS - 1) / 3 * np.eye(3)
    assert np.all(np.abs(tensor - expected) < TOLERANCE_SIGMAS * tensor_error)
    # Bond tensor: <Q Q> = (l^2/3) I; 30000 independent bonds, per-component standard
    # deviation of Q_a Q_b at most sqrt(2) l^2/3 < 0.5.
    bonds = conf.bond_vectors(x)
    bond_tensor = np.asarray(conf.conformation_tensor(bonds, axis=(0, 1)))
    assert np.allclose(bond_tensor, np.eye(3) / 3, atol=TOLERANCE_SIGMAS * 0.5 / np.sqrt(30000))


def test_hydrodynamic_radius_of_gaussian_chains(chains):
    """Kirkwood <1/R_H> = N^-2 sum_{i != j} <1/r_ij> (Ahlrichs & Dünweg eq. 26) against
    the exact discrete Gaussian-chain value (2/N^2) sum_k (N-k) sqrt(6/pi)/sqrt(k), and the
    latter against the asymptotic series of Mussawisade et al. eq. 15 (Dünweg et al. 2002).
    Expanding the exact sum (Euler-Maclaurin) shows the first neglected term of eq. 15 is
    +(9/16) zeta(1/2)^2 / N relative (the printed O(N^-3/2) holds for 1/R_H, not R_H);
    with it the series matches the exact value to O(N^-3/2)."""
    inverse = np.asarray(conf.inverse_hydrodynamic_radius(jnp.asarray(chains)))
    mean, error = mean_and_error(inverse)
    exact = conf.gaussian_chain_inverse_hydrodynamic_radius(N_BEADS)
    assert abs(mean - exact) < TOLERANCE_SIGMAS * error
    zeta_half = -1.4603545088095868
    asymptotic_radius = (
        3 / 8 * np.sqrt(np.pi / 6) * np.sqrt(N_BEADS) * (1 - 0.75 * zeta_half / np.sqrt(N_BEADS))
    )
    second_order = 9 / 16 * zeta_half**2 / N_BEADS
    assert abs(asymptotic_radius * exact - 1 + second_order) < N_BEADS**-1.5
    gradient = jax.grad(lambda x: conf.inverse_hydrodynamic_radius(x).sum())(
        jnp.asarray(chains[:4])
    )
    assert np.all(np.isfinite(gradient))


def test_extension_float32_and_bad_arguments():
    """A straight chain of unit bonds has fractional extension 1; float32 stays float32."""
    straight = np.zeros((1, 5, 3), np.float32)
    straight[0, :, 0] = np.arange(5)
    extension = conf.fractional_extension(jnp.asarray(straight), contour_length=4.0)
    assert extension.dtype == jnp.float32
    np.testing.assert_allclose(extension, [1.0])
    assert conf.gyration_radius_squared(jnp.asarray(straight)).dtype == jnp.float32
    np.testing.assert_allclose(conf.gyration_radius_squared(jnp.asarray(straight)), [2.0])
    with pytest.raises(ValueError, match="contour_length"):
        conf.fractional_extension(straight, contour_length=0.0)
    with pytest.raises(ValueError, match="normalization"):
        conf.rouse_modes(straight, normalization="doi")
    with pytest.raises(ValueError, match="last axis is not 3"):
        conf.gyration_radius_squared(np.zeros((2, 5, 2)))
    with pytest.raises(ValueError, match="dtype"):
        conf.end_to_end_vector(np.zeros((2, 5, 3), np.int32))
    with pytest.raises(ValueError, match="axis"):
        conf.conformation_tensor(np.zeros((4, 3)), axis=-1)
