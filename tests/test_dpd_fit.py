"""Traced model parameters and the sensitivity estimators of jaxdpd.studies.dpd_fit.

References:
- each bond law bound to traced values equals the law built from the same numbers
  (jaxdpd.forces.bonds, exact to round-off);
- the canonical fluctuation formula d⟨A⟩/dθ = −(⟨A U_θ⟩ − ⟨A⟩⟨U_θ⟩)/k_BT on samples
  drawn exactly from the Boltzmann distribution of free FENE springs, whose
  ⟨Q²⟩ = 3 Q0²/(b + 5), b = H Q0²/k_BT (thesis eq. 4.8), gives
  d⟨Q²⟩/dH = −3 Q0⁴/(k_BT (b + 5)²);
- replicas of a vmapped ensemble read their own parameters, and the tagged body
  force conserves the total (peculiar) momentum (its forces sum to zero);
- slow: d⟨Q²⟩/dH of DPD dumbbells by the canonical formula equals central finite
  differences, and an optax fit recovers H from a target ⟨Q²⟩ (must-show 7).

Tolerances: 4 standard errors of independent samples or block averages.
"""

import jax
import jax.numpy as jnp
import numpy as np
import pytest
from dumbbell_scenes import dumbbell_solution, sheared_solution_with_tracers

from jaxdpd import brownian as bd
from jaxdpd.engine.build import build
from jaxdpd.engine.parameters import with_parameters
from jaxdpd.forces import bonds
from jaxdpd.geometry.boxes import PeriodicBox
from jaxdpd.run import driver, ensemble
from jaxdpd.studies.dpd_fit import (
    canonical_sensitivity,
    fit_bond_parameter,
    independent_spring_sensitivity,
    measure_sensitivity,
    sensitivity_simulation,
)

SIGMAS = 4.0
LAWS = {
    "hookean": bonds.bond_law({"law": "hookean", "spring_constant": 2.0}, kT=1.0),
    "fraenkel": bonds.bond_law(
        {"law": "fraenkel", "spring_constant": 30.0, "rest_length": 0.8}, kT=1.0
    ),
    "harmonic": bonds.bond_law(
        {"law": "harmonic", "spring_constant": 30.0, "rest_length": 0.8}, kT=1.0
    ),
    "fene": bonds.bond_law({"law": "fene", "spring_constant": 0.5, "max_extension": 5.0}, kT=1.0),
    "fene_log_wca": bonds.bond_law(
        {"law": "fene_log_wca", "spring_constant": 30.0, "max_extension": 1.5}, kT=1.0
    ),
}
CHANGED = {
    "hookean": {"spring_constant": 3.0},
    "fraenkel": {"spring_constant": 20.0, "rest_length": 0.9},
    "harmonic": {"spring_constant": 20.0, "rest_length": 0.9},
    "fene": {"spring_constant": 0.7, "max_extension": 4.0},
    "fene_log_wca": {
        "spring_constant": 25.0,
        "max_extension": 1.6,
        "wca_epsilon": 1.2,
        "wca_sigma": 0.9,
    },
}


@pytest.mark.parametrize("name", list(LAWS))
def test_bond_law_with_traced_parameters_equals_the_law_of_those_numbers(name):
    law = LAWS[name]
    rng = np.random.default_rng(1)
    directions = rng.normal(size=(4, 3, 3))
    directions /= np.linalg.norm(directions, axis=-1, keepdims=True)
    steps = directions * rng.uniform(0.6, 1.2, size=(4, 3, 1))
    chains = np.concatenate([np.zeros((4, 1, 3)), np.cumsum(steps, axis=1)], axis=1) + 5.0
    box = PeriodicBox((12.0, 12.0, 12.0))
    image = jnp.zeros(chains.shape, jnp.int32)
    values = CHANGED[name]
    expected_law = bonds.bond_law({"law": name, **values}, kT=1.0)
    expected = bonds.chain_bond_forces(box, jnp.asarray(chains), image, expected_law, True)

    @jax.jit
    def traced(parameters):
        result = bonds.chain_bond_forces(
            box, jnp.asarray(chains), image, law.with_parameters(parameters), True
        )
        return result.forces, result.virial

    forces, virial = traced({key: jnp.asarray(value) for key, value in values.items()})
    np.testing.assert_allclose(forces, expected.forces, rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(virial, expected.virial, rtol=1e-12, atol=1e-12)
    q_sq = jnp.linspace(0.3, 1.2, 7)
    np.testing.assert_allclose(
        law.with_parameters(values).energy(q_sq), expected_law.energy(q_sq), rtol=1e-12
    )


def fene_samples(key, spring_constant, max_extension, n_springs, n_steps):
    """Exact equilibrium FENE connectors (units r_c, k_BT = 1), (T, S, 3)."""
    b = spring_constant * max_extension**2
    dimensionless = bd.FENE(b).sample_equilibrium(key, n_springs * n_steps, jnp.float64)
    return np.asarray(dimensionless).reshape(n_steps, n_springs, 3) / np.sqrt(spring_constant)


def test_canonical_sensitivity_of_exact_fene_samples():
    """d⟨Q²⟩/dH of free FENE springs (H = 2, Q0 = 2.5, b = 12.5) from exactly
    Boltzmann-distributed samples: both estimators agree with −3 Q0⁴/(b + 5)²."""
    h, q0, springs, steps = 2.0, 2.5, 50, 4000
    q = fene_samples(jax.random.key(2), h, q0, springs, steps)
    q_sq = np.sum(q * q, axis=-1)
    law = bonds.bond_law({"law": "fene", "spring_constant": h, "max_extension": q0}, kT=1.0)
    energy_derivative = jax.vmap(
        jax.grad(lambda value, x: law.with_parameters({"spring_constant": value,
                                                       "max_extension": q0}).energy(x)),
        in_axes=(None, 0),
    )  # fmt: skip
    u = np.asarray(energy_derivative(jnp.asarray(h), jnp.asarray(q_sq.ravel()))).reshape(q_sq.shape)
    a = q_sq.mean(axis=1)
    exact = -3 * q0**4 / (h * q0 * q0 + 5) ** 2
    derivative, error = canonical_sensitivity(a, u.sum(axis=1), kT=1.0)
    assert abs(float(derivative) - exact) < SIGMAS * float(error), (derivative, error, exact)
    independent, independent_error = independent_spring_sensitivity(
        a, u.sum(axis=1), (q_sq * u).mean(axis=1), springs, kT=1.0
    )
    assert abs(float(independent) - exact) < SIGMAS * float(independent_error)
    # Independent springs: the per-spring estimator has about √S times less noise.
    assert float(independent_error) < float(error) / np.sqrt(springs) * 2


def test_with_parameters_refuses_unknown_keys_and_other_dtypes():
    state = make_state_like()
    with pytest.raises(ValueError, match="parameters.bond.solvent: not a traced parameter"):
        with_parameters(state, {"bond": {"solvent": {"spring_constant": 1.0}}})
    with pytest.raises(ValueError, match=r"parameters.bond.dumbbell.length.*valid keys"):
        with_parameters(state, {"bond": {"dumbbell": {"length": 1.0}}})
    with pytest.raises(TypeError, match="float32.*float64"):
        with_parameters(
            state, {"bond": {"dumbbell": {"spring_constant": jnp.asarray(1.0, jnp.float32)}}}
        )
    with pytest.raises(ValueError, match="finite"):
        with_parameters(state, {"body_force": {"amplitude": float("nan")}})
    updated = with_parameters(state, {"body_force": {"amplitude": 2}})
    assert updated.parameters["body_force"]["amplitude"].dtype == jnp.float64
    assert float(updated.parameters["bond"]["dumbbell"]["spring_constant"]) == 4.0


def make_state_like():
    from jaxdpd.engine.state import SimState

    parameters = {
        "bond": {
            "dumbbell": {
                "spring_constant": jnp.asarray(4.0),
                "max_extension": jnp.asarray(1.5),
            }
        },
        "body_force": {"amplitude": jnp.asarray(1.0)},
    }
    zeros = jnp.zeros((2, 3))
    return SimState(
        zeros, zeros, zeros, zeros, zeros, None, {}, 0, 0.0, 0, 0, parameters=parameters
    )


def test_replicas_read_their_own_parameters_and_conserve_momentum():
    """Three vmapped replicas, same seed and start: the third has the first's spring
    constant and tagged force and follows it exactly; the second (other values)
    departs from it, so each replica's kernels read its own parameters.  The total
    peculiar momentum stays at its start value in every replica (the tagged force is
    balanced; SLLOD keeps Σ c, thesis eqs. 3.42–3.43)."""
    simulation = build(sheared_solution_with_tracers())
    start = simulation.init_fn()
    first = {"bond": {"dumbbell": {"spring_constant": 3.0}}, "body_force": {"amplitude": 1.0}}
    other = {"bond": {"dumbbell": {"spring_constant": 2.0}}, "body_force": {"amplitude": 3.0}}
    states = [with_parameters(start, values) for values in (first, other, first)]
    batch = driver.run(simulation, ensemble.replicate(simulation, states, seeds=[5] * 3), 40, 20)
    positions = np.asarray(batch.positions)
    np.testing.assert_array_equal(positions[2], positions[0])
    assert np.abs(positions[1] - positions[0]).max() > 1e-3
    spring_constants = batch.parameters["bond"]["dumbbell"]["spring_constant"]
    np.testing.assert_array_equal(spring_constants, [3.0, 2.0, 3.0])
    velocities = np.asarray(batch.velocities)
    drift = velocities.sum(axis=1) - np.asarray(start.velocities).sum(axis=0)
    assert np.abs(drift).max() < 1e-10 * np.abs(velocities).sum(axis=(1, 2)).min()


FIT_SPRING_CONSTANT, FIT_MAX_EXTENSION = 2.0, 2.5  # b = 12.5


def fit_scene():
    """424 particles (box 5.24), half of them in 106 FENE dumbbells (Q0 = 2.5,
    H = 2), θ-solvent a = 25 for all pairs (thesis §4.2.9); float32."""
    return dumbbell_solution(
        424,
        212,
        FIT_SPRING_CONSTANT,
        FIT_MAX_EXTENSION,
        precision="float32",
        integrator={"dt": 0.04, "lambda": 0.65},
        output={"observables": ["temperature"]},
    )


@pytest.fixture(scope="module")
def fit_setup():
    """The built scene, its sensitivity simulation (compiled once for the module)
    and a state equilibrated at H = 2."""
    simulation = build(fit_scene())
    sensitivity = sensitivity_simulation(simulation, "dumbbell", "spring_constant")
    state = driver.run(sensitivity, simulation.init_fn(), 2000, 500)
    return simulation, sensitivity, state


@pytest.mark.slow
def test_fluctuation_derivative_equals_central_finite_difference(fit_setup):
    """d⟨Q²⟩/dH at H = 2 by the canonical formula (one run) and by central finite
    differences over H(1 ± 0.1) with common random numbers (same seed and start),
    the three runs as one vmapped ensemble.  The finite difference's truncation
    error, (δ b/(b + 5))² ≈ 0.5 % for the ideal FENE law, is far below its
    statistical error (≈ 3 %)."""
    simulation, sensitivity, start = fit_setup
    delta = 0.1
    values = FIT_SPRING_CONSTANT * np.array([1 - delta, 1.0, 1 + delta])
    states = [
        with_parameters(
            start, {"bond": {"dumbbell": {"spring_constant": jnp.asarray(h, jnp.float32)}}}
        )
        for h in values
    ]
    batch = ensemble.replicate(simulation, states, seeds=[31] * 3)
    batch = driver.run(sensitivity, batch, 1000, 500)
    _, result = measure_sensitivity(sensitivity, batch, 8000, 500, kT=1.0, n_springs=106)
    step = 2 * delta * FIT_SPRING_CONSTANT
    difference = (result.value[2] - result.value[0]) / step
    difference_error = np.hypot(result.value_error[2], result.value_error[0]) / step
    print(f"⟨Q²⟩ = {result.value}; dA/dH: finite difference {difference:.4f} ± "
          f"{difference_error:.4f}, canonical {result.derivative[1]:.4f} ± "
          f"{result.derivative_error[1]:.4f}, independent springs {result.independent[1]:.4f} "
          f"± {result.independent_error[1]:.4f}")  # fmt: skip
    for estimate, error in (
        (result.derivative[1], result.derivative_error[1]),
        (result.independent[1], result.independent_error[1]),
    ):
        assert abs(estimate - difference) < SIGMAS * np.hypot(error, difference_error)


@pytest.mark.slow
def test_gradient_fit_recovers_the_spring_constant(fit_setup):
    """Must-show 7: the target ⟨Q²⟩ comes from a run at H = 2; an optax Gauss–Newton
    fit through the DPD engine (canonical-fluctuation gradients, one compiled step for
    every H) started 30 % off (H = 2.6) returns H within 2 % (and within 4 of its
    combined standard errors: the target's, propagated through the slope, and the
    fit's)."""
    simulation, sensitivity, state = fit_setup
    state, target = measure_sensitivity(sensitivity, state, 24000, 500, kT=1.0, n_springs=106)
    fit = fit_bond_parameter(
        simulation,
        state,
        species="dumbbell",
        parameter="spring_constant",
        target=float(target.value),
        start=1.3 * FIT_SPRING_CONSTANT,
        iterations=10,
        steps=6000,
        equilibration=500,
        chunk=500,
        sensitivity=sensitivity,
    )
    target_error = float(target.value_error / abs(target.derivative))
    print(f"target ⟨Q²⟩ = {float(target.value):.4f} ± {float(target.value_error):.4f}; H "
          f"iterates {np.round(fit.parameters, 4)}; estimate {fit.estimate:.4f} ± "
          f"{fit.estimate_error:.4f} (target error {target_error:.4f})")  # fmt: skip
    distances = np.abs(fit.parameters - FIT_SPRING_CONSTANT)
    assert distances[1] < distances[0]  # the first step goes the right way
    assert abs(fit.estimate / FIT_SPRING_CONSTANT - 1) < 0.02
    error = np.hypot(fit.estimate_error, target_error)
    assert abs(fit.estimate - FIT_SPRING_CONSTANT) < SIGMAS * error
