"""Equilibrium statistics of ideal chains and FENE dumbbells in a DPD thermostat.

Without conservative pair forces the chains are ideal: the Groot–Warren thermostat
only samples the canonical distribution of the bond energy.  References:
- Gaussian (Hookean, zero rest length) chain of M beads, ⟨l²⟩ = 3 k_BT/H:
  ⟨R_e²⟩ = (M − 1) l²,  ⟨R_g²⟩ = l² (M² − 1)/(6M)  (Doi & Edwards, The Theory of
  Polymer Dynamics (1986), §2.1; Mussawisade et al. eq. 3 for the Gaussian chain);
- FENE dumbbell: ⟨Q²⟩/Q0² = 3/(b + 5), b = H Q0²/k_BT  (Bird et al., thesis eq. 4.8).

Tolerance of every comparison: 4 standard errors of the block-averaged time series,
plus the systematic errors of the time step, each estimated in the run itself:
- the thermostat's temperature error |⟨k_BT⟩_kinetic − k_BT| (⟨Q²⟩ ∝ k_BT for a
  Gaussian chain, and grows more slowly than k_BT for FENE), and
- velocity Verlet's configurational bias of a harmonic mode, (ω Δt)²/4 relative
  (from its shadow Hamiltonian; Allen & Tildesley, 2nd ed. (2017), §3.2), with ω the
  fastest spring mode.
"""

import math

import numpy as np
import pytest
from conftest import make_scene

from jaxdpd.analysis.statistics import block_average
from jaxdpd.engine.build import build
from jaxdpd.run import driver

DT = 0.02
Q0 = 3.0
CHAIN_BEADS = 6
HOOKEAN = 3.0  # l² = 3 k_BT/H = 1


def _fene_constant(b):
    return b / Q0**2


def ideal_polymer_scene(seed=11):
    """Dumbbells with b = 10 and b = 50 and Hookean 6-bead chains, no pair force."""
    fene = {"law": "fene", "max_extension": Q0}
    return make_scene(
        seed=seed,
        precision="float32",
        particles={
            "density": 2.0,
            "count": 1200,
            "species": [
                {"name": "b10", "count": 300},
                {"name": "b50", "count": 300},
                {"name": "chain", "count": 600},
            ],
        },
        pair=None,
        polymers=[
            {"species": "b10", "beads": 2, "bond": {**fene, "spring_constant": _fene_constant(10)}},
            {"species": "b50", "beads": 2, "bond": {**fene, "spring_constant": _fene_constant(50)}},
            {
                "species": "chain",
                "beads": CHAIN_BEADS,
                "bond": {"law": "hookean", "spring_constant": HOOKEAN},
            },
        ],
        integrator={"dt": DT, "lambda": 0.65},
        output={"observables": ["temperature", "conformation"]},
    )


def _run(scene, equilibration, steps):
    simulation = build(scene)
    state = driver.run(simulation, simulation.init_fn(), equilibration, 500)
    parts = {}

    def collect(result):
        for name, values in result.series.items():
            parts.setdefault(name, []).append(np.asarray(values, np.float64))

    driver.run(simulation, state, steps, 500, on_chunk=collect)
    return {name: np.concatenate(values) for name, values in parts.items()}


def _verlet_bias(stiffness):
    """(ω Δt)²/4 for a spring of the given stiffness between two unit masses."""
    omega = math.sqrt(2 * stiffness)
    return (omega * DT) ** 2 / 4


def _check(series, expected, bias):
    mean, error = block_average(series, n_blocks=20)
    tolerance = 4 * float(error) + bias * expected
    assert abs(float(mean) - expected) < tolerance, (float(mean), expected, float(error), bias)


def _check_ideal_statistics(series):
    kT_error = abs(float(np.mean(series["temperature"])) - 1.0)
    for b in (10, 50):
        expected = Q0**2 * 3 / (b + 5)
        # Stiffness dT/dQ = H (1 + x)/(1 − x)², x = Q²/Q0², at three times ⟨Q²⟩.
        x = 3 * expected / Q0**2
        stiffness = _fene_constant(b) * (1 + x) / (1 - x) ** 2
        _check(series[f"b{b}/bond_length_sq"], expected, kT_error + _verlet_bias(stiffness))
    # Fastest mode of a Hookean chain of unit masses: ω² = 4H (at most).
    bias = kT_error + _verlet_bias(2 * HOOKEAN)
    l_sq = 3.0 / HOOKEAN
    m = CHAIN_BEADS
    _check(series["chain/end_to_end_sq"], (m - 1) * l_sq, bias)
    _check(series["chain/gyration_radius_sq"], l_sq * (m * m - 1) / (6 * m), bias)
    _check(series["chain/bond_length_sq"], l_sq, bias)


# Long statistical validations (2500 steps of 1200 particles, and 10× that): -m slow.
# The default run keeps the bond forces (test_bonds.py), the exact FENE ⟨Q²⟩ of the
# equilibrium sampler (test_brownian_dynamics.py), DPD chains and dumbbells run with
# their conformation observables (test_chain_correlators.py) and the Gaussian-chain
# estimators (test_polymer_conformation.py).
@pytest.mark.slow
def test_ideal_chain_and_fene_dumbbell_statistics():
    _check_ideal_statistics(_run(ideal_polymer_scene(), 500, 2000))


@pytest.mark.slow
def test_ideal_chain_and_fene_dumbbell_statistics_long():
    """The same with 10× the samples: tolerances ~3× tighter."""
    _check_ideal_statistics(_run(ideal_polymer_scene(seed=12), 500, 20000))
