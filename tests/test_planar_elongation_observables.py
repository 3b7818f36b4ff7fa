"""Observables of planar elongation on hand-built inputs (nothing is simulated).

References:
- thesis eqs. 3.25–3.26 with the velocity gradient of eq. 5.12: for a Newtonian
  stress σ = −p I + η (L + Lᵀ) the material functions are η̄1 = 4η and η̄2 = 2η
  (the planar Trouton ratios of thesis §4.3.3);
- a straight chain of M beads a bond length l apart has |R_e| = (M − 1) l,
  R_g² = l² (M² − 1)/12 and fractional extension l/Q_0, wherever the periodic
  boundaries cut it (thesis §3.2.4: chains are rebuilt by minimum-image springs).
"""

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from jaxdpd.analysis.elongation import (
    elongational_material_functions,
    elongational_viscosities,
)
from jaxdpd.forces.bonds import bond_law
from jaxdpd.geometry.boxes import KraynikReineltBox
from jaxdpd.geometry.chain_topology import ChainBlock
from jaxdpd.observables.chain_series import conformation_samples

LENGTHS = (6.0, 4.0, 6.0)


def newtonian_pressure_tensor(box, rate, viscosity, pressure):
    """P = −σ = p I − η (L + Lᵀ) with L the box's velocity gradient at rate ε̇."""
    state = box.initial_state(jnp.float64).set(elongation_rate=jnp.asarray(rate))
    gradient = np.asarray(box.bind(state).velocity_gradient)
    return pressure * np.eye(3) - viscosity * (gradient + gradient.T)


def test_newtonian_stress_has_the_planar_trouton_ratios():
    """η̄1 = 4η, η̄2 = 2η for both signs of ε̇, from the box's own L (so the axes of
    the box and of the material functions agree); the same for the polymer part and
    for an ensemble's (B, T, 3, 3) series with one rate per replica."""
    box = KraynikReineltBox(LENGTHS)
    viscosity, pressure = 0.85, 23.6
    for rate in (0.3, -0.05):
        eta1, eta2 = elongational_viscosities(
            newtonian_pressure_tensor(box, rate, viscosity, pressure), rate
        )
        np.testing.assert_allclose([eta1, eta2], [4 * viscosity, 2 * viscosity], rtol=1e-12)
    rates = np.array([0.1, 0.2])
    tensors = np.stack([newtonian_pressure_tensor(box, r, viscosity, pressure) for r in rates])
    series = np.broadcast_to(tensors[:, None], (2, 40, 3, 3))
    polymer_viscosity = 0.2
    polymer = np.stack([newtonian_pressure_tensor(box, r, polymer_viscosity, 3.0) for r in rates])
    functions = elongational_material_functions(
        {
            "pressure_tensor": series,
            "pressure_tensor_part/bond": np.broadcast_to(polymer[:, None], (2, 40, 3, 3)),
        },
        rates,
        axis=1,
    )
    for name, ratio in (("eta1", 4), ("eta2", 2)):
        np.testing.assert_allclose(functions[name][0], [ratio * viscosity] * 2, rtol=1e-12)
        np.testing.assert_allclose(
            functions[f"{name}_polymer"][0], [ratio * polymer_viscosity] * 2, rtol=1e-12
        )
    with pytest.raises(ValueError, match="ε̇ ≠ 0"):
        elongational_viscosities(series, 0.0)
    with pytest.raises(ValueError, match="add 'pressure'"):
        elongational_material_functions({}, 0.1)


@pytest.mark.parametrize("strain", [-0.48, -0.1, 0.2, 0.47])
def test_straight_chain_cut_by_the_deforming_faces_keeps_its_shape(strain):
    """A straight FENE chain (M = 5, l = 1.5, Q_0 = 2) laid across the faces of the
    cell at strains spread over the period and wrapped into it: the conformation
    samples rebuild it, with ⟨Q²⟩ = l², R_e² = (4 l)², R_g² = l² (M² − 1)/12 and
    fractional extension l/Q_0."""
    beads, bond, q0 = 5, 1.5, 2.0
    box = KraynikReineltBox(LENGTHS, 0.4)
    bound = box.bind(box.initial_state(jnp.float64).set(strain=jnp.asarray(strain)))
    direction = np.array([0.6, 0.48, -0.64])  # a unit vector
    corner = np.asarray(box.centre) + 0.45 * np.asarray(bound.lattice_vectors).sum(axis=1)
    raw = corner + bond * np.arange(beads)[:, None] * direction
    positions, image = bound.wrap(jnp.asarray(raw), jnp.zeros((beads, 3), jnp.int32))
    assert np.any(np.asarray(image) != 0), "the chain must cross a face"
    block = ChainBlock(
        "chain",
        0,
        1,
        beads,
        bond_law({"law": "fene", "spring_constant": 30.0, "max_extension": q0}, kT=1.0),
    )
    # One compiled call rather than op-by-op dispatch (much faster to run).
    samples = jax.jit(lambda wrapped: conformation_samples(bound, wrapped, [block]))(positions)
    expected = {
        "chain/bond_length_sq": bond**2,
        "chain/end_to_end_sq": ((beads - 1) * bond) ** 2,
        "chain/gyration_radius_sq": bond**2 * (beads**2 - 1) / 12,
        "chain/fractional_extension": bond / q0,
        "chain/fractional_extension_sq": (bond / q0) ** 2,
        # ⟨Q Q⟩ and R_e R_e of a straight chain: the outer products of its direction.
        "chain/bond_conformation": bond**2 * np.outer(direction, direction),
        "chain/end_to_end_conformation": ((beads - 1) * bond) ** 2 * np.outer(direction, direction),
    }
    assert samples.keys() == expected.keys()
    for name, value in expected.items():
        np.testing.assert_allclose(samples[name], value, rtol=1e-12, atol=1e-12, err_msg=name)


def test_replica_jackknife_gives_the_spread_of_the_relaxation_fit():
    """Jackknife errors over replicas (jaxdpd.studies.relaxation.replica_jackknife) match the
    true scatter of the fitted eq. 5.15 parameters for curves whose noise is
    correlated in time (AR(1), correlation 0.95 per point, as in a sampled run), where
    the fit's own errors, which take the points as independent, are too small.
    Reference: the standard deviation of the fitted values over 200 independent
    synthetic ensembles of 8 replicas (its own relative error ≈ 1/√400 = 5 %; the RMS
    jackknife error is averaged over the same 200).  The jackknife variance is biased
    upwards (Efron & Stein, Ann. Stat. 9, 586 (1981)), so the RMS jackknife error may
    not fall below 0.8 of the true spread (4 of those 5 % errors) and must stay below
    1.5 of it to be of use."""
    from jaxdpd.analysis.fits import fit_end_to_end_relaxation
    from jaxdpd.studies.relaxation import replica_jackknife

    rng = np.random.default_rng(5)
    times = np.arange(2.0, 25.0, 0.2)
    truth = 50.0 * np.exp(-times / 1.5) + 9.5
    replicas, correlation = 8, 0.95
    fitted, jackknife, naive = [], [], []
    for _ in range(200):
        noise = np.empty((replicas, len(times)))
        noise[:, 0] = rng.normal(size=replicas)
        for k in range(1, len(times)):
            kick = rng.normal(size=replicas) * np.sqrt(1 - correlation**2)
            noise[:, k] = correlation * noise[:, k - 1] + kick
        curves = truth + 2.0 * noise
        mean = curves.mean(axis=0)
        error = curves.std(axis=0, ddof=1) / np.sqrt(replicas)
        fit = fit_end_to_end_relaxation(times, mean, error)
        fitted.append(fit.values)
        naive.append(fit.errors)
        jackknife.append(replica_jackknife(fit, times, curves).errors)
    spread = np.std(fitted, axis=0, ddof=1)
    jackknife_rms = np.sqrt(np.mean(np.square(jackknife), axis=0))
    assert np.all(jackknife_rms > 0.8 * spread) and np.all(jackknife_rms < 1.5 * spread), (
        jackknife_rms,
        spread,
    )
    # The plateau is what correlation hides most: the naive error is far too small.
    plateau = fit.names.index("plateau")
    assert np.sqrt(np.mean(np.square(naive), axis=0))[plateau] < 0.5 * spread[plateau]
