"""Lowe–Andersen DPD fluids: momentum, temperature, Maxwellian velocities.

References: Lowe, Europhys. Lett. 47, 145 (1999); thesis §2.3.2 and table 2.1 (the
algorithm), §4.3 ("no simulation shows a temperature error greater than 0.5 %" at
Δt = 0.01 with Γ up to 80, FENE dumbbells in a DPD solvent), eq. 3.47 (stress).
"""

import jax.numpy as jnp
import numpy as np
import pytest
from scipy import stats

from jaxdpd.analysis.statistics import block_average
from jaxdpd.engine import noise
from jaxdpd.engine.build import build
from jaxdpd.forces.pair_laws import soft_repulsion
from jaxdpd.run import driver
from jaxdpd.scene import Scene
from jaxdpd.solvents import lowe_andersen as la

KT, DT, REPULSION = 1.0, 0.01, 25.0
FENE = {"law": "fene", "spring_constant": 8.0, "max_extension": 2.5}  # b = H Q0²/kT = 50


def dumbbell_fluid(probability: float, count: int = 600) -> Scene:
    """FENE dumbbells (10 % of the particles) in a ρ = 3, a = 25 Lowe–Andersen
    solvent at Δt = 0.01 and Γ = probability/Δt (the thesis ch. 4 setting at ρ = 3)."""
    return Scene.from_dict(
        {
            "seed": 11,
            "precision": "float64",
            "particles": {
                "density": 3.0,
                "count": count,
                "species": [
                    {"name": "dumbbell", "fraction": 0.1},
                    {"name": "solvent", "fraction": 0.9},
                ],
            },
            "solvent": {
                "method": "lowe_andersen",
                "kT": KT,
                "collision_frequency": probability / DT,
            },
            "pair": {"a": REPULSION},
            "polymers": [{"species": "dumbbell", "beads": 2, "bond": FENE}],
            "integrator": {"dt": DT},
            "output": {"observables": ["temperature", "pressure"]},
        }
    )


def run_fluid(scene, equilibration: int, steps: int, chunk: int):
    """Run from the scene's seed; collect per-step series and chunk-end states
    (one chunk length throughout: one compilation)."""
    simulation = build(scene)
    start = simulation.init_fn()
    state = driver.run(simulation, start, equilibration, chunk)
    series, snapshots = {}, []

    def collect(result):
        for name, values in result.series.items():
            series.setdefault(name, []).append(values)
        snapshots.append(result.state)

    driver.run(simulation, state, steps, chunk, on_chunk=collect)
    series = {name: np.concatenate(parts) for name, parts in series.items()}
    return start, series, snapshots


@pytest.fixture(scope="module")
def fluid():
    """ΓΔt = 1 (every pair within r_c thermalised every step), 600 particles.
    Chunk ends are 1 time unit apart, far beyond the velocity relaxation time."""
    scene = dumbbell_fluid(1.0)
    return scene, *run_fluid(scene, equilibration=200, steps=1500, chunk=100)


def test_total_momentum_is_conserved_to_round_off(fluid):
    """Conservative, bond and thermostat momentum changes are pairwise equal and
    opposite: Σ p is constant to float64 round-off (≪ 1e-10 Σ|p| over 1700 steps)."""
    _, start, _, snapshots = fluid
    final = np.asarray(snapshots[-1].velocities)
    drift = np.abs(final.sum(axis=0) - np.asarray(start.velocities).sum(axis=0)).max()
    assert drift <= 1e-10 * np.abs(final).sum(), drift


def assert_temperature_within_half_percent(temperature, largest_error):
    """⟨k_BT⟩ within 0.5 % of the set value (thesis §4.3), with a standard error
    from 20 block averages below `largest_error` (relative), so that the check
    resolves 0.5 %."""
    mean, error = (float(x) for x in block_average(temperature, n_blocks=20))
    assert error < largest_error * KT, (mean, error)
    assert abs(mean - KT) < 5e-3 * KT, (mean, error)


def test_temperature_within_half_percent_at_unit_collision_probability(fluid):
    """ΓΔt = 1, Δt = 0.01; standard error ≈ 0.09 %, required below 0.15 %, so a
    deviation of 0.5 % would be ≥ 3.3 standard errors.  (Thermalising the half-step
    velocity instead, a misreading of table 2.1, measures +1.3 % here and fails.)"""
    _, _, series, _ = fluid
    assert_temperature_within_half_percent(series["temperature"], 1.5e-3)


def disjoint_pairs(i, j, n_particles, rng):
    """Indices of pairs that share no particle (nearly independent samples): the
    pairs whose random rank is the smallest at both their particles."""
    rank = rng.permutation(len(i))
    smallest = np.full(n_particles, len(i))
    np.minimum.at(smallest, i, rank)
    np.minimum.at(smallest, j, rank)
    return np.nonzero((smallest[i] == rank) & (smallest[j] == rank))[0]


def thermalized_pair_velocities(scene, state, rng):
    """Relative normal velocities u_ij = (v_i − v_j)·e_ij, in units of √(k_BT/μ),
    of disjoint pairs thermalised in the step that ended at `state`."""
    positions, velocities = np.asarray(state.positions), np.asarray(state.velocities)
    side = np.asarray(scene.box.lengths)
    i, j = np.triu_indices(len(positions), 1)
    key = noise.step_key(scene.seed, int(state.step))
    probability = scene.solvent.collision_frequency * scene.integrator.dt
    # Drawn for all pairs (one array shape for every snapshot), kept within r_c.
    chosen = np.asarray(la.selected(key, jnp.asarray(i), jnp.asarray(j), probability, np.float64))
    separation = positions[i] - positions[j]
    separation -= side * np.round(separation / side)
    distance = np.linalg.norm(separation, axis=1)
    chosen = chosen & (distance < scene.cutoff)
    keep = disjoint_pairs(i[chosen], j[chosen], len(positions), rng)
    i, j = i[chosen][keep], j[chosen][keep]
    unit = separation[chosen][keep] / distance[chosen][keep, None]
    normal = np.sum((velocities[i] - velocities[j]) * unit, axis=1)
    return normal / np.sqrt(KT / 0.5)  # μ = ½ for unit masses


def test_thermalised_pairs_have_maxwellian_relative_velocities(fluid):
    """After the sweep, a thermalised pair's relative normal velocity is N(0, k_BT/μ)
    (Maxwell distribution of a pair, thesis eq. 2.19).  Disjoint pairs from snapshots
    1 time unit apart are nearly independent samples: Kolmogorov–Smirnov against the
    standard normal at significance 0.1 % (p > 1e-3), and the variance 1 within five
    standard errors √(2/n)."""
    scene, _, _, snapshots = fluid
    rng = np.random.default_rng(1)
    samples = np.concatenate([thermalized_pair_velocities(scene, s, rng) for s in snapshots])
    assert len(samples) > 1000
    assert stats.kstest(samples, "norm").pvalue > 1e-3
    assert abs(np.mean(samples**2) - 1) < 5 * np.sqrt(2 / len(samples))


def test_impulse_virial_is_a_part_of_the_pressure_tensor(fluid):
    """The pressure tensor holds kinetic, conservative, bond and Lowe–Andersen impulse
    parts (thesis eqs. 3.47–3.49); the conservative and bond parts equal their
    brute-force values at the final configuration, and the impulse part, reported
    on its own, closes the sum."""
    scene, _, series, snapshots = fluid
    state = snapshots[-1]
    positions, velocities = np.asarray(state.positions), np.asarray(state.velocities)
    side = np.asarray(scene.box.lengths)
    volume = float(np.prod(side))
    part = {
        name: series[f"pressure_tensor_part/{name}"][-1] * volume
        for name in ("kinetic", "conservative", "bond", "impulse")
    }
    i, j = np.triu_indices(len(positions), 1)
    separation = positions[i] - positions[j]
    separation -= side * np.round(separation / side)
    distance = np.linalg.norm(separation, axis=1)
    near = distance < scene.cutoff
    magnitude = soft_repulsion(1 - distance[near] / scene.cutoff, REPULSION) / distance[near]
    conservative = np.einsum("pa,pb,p->ab", separation[near], separation[near], magnitude)
    np.testing.assert_allclose(part["conservative"], conservative, rtol=1e-10, atol=1e-8)
    beads = scene.particles.species[0].count
    spring = positions[1:beads:2] - positions[0:beads:2]
    spring -= side * np.round(spring / side)
    tension = FENE["spring_constant"] / (1 - np.sum(spring**2, axis=1) / FENE["max_extension"] ** 2)
    bond = -np.einsum("pa,pb,p->ab", spring, spring, tension)  # −Σ Q ⊗ H Q/(1 − Q²/Q0²)
    np.testing.assert_allclose(part["bond"], bond, rtol=1e-10, atol=1e-8)
    np.testing.assert_allclose(part["kinetic"], velocities.T @ velocities, rtol=1e-12)
    np.testing.assert_allclose(
        series["pressure_tensor"][-1] * volume, sum(part.values()), rtol=1e-12, atol=1e-9
    )
    assert np.abs(part["impulse"]).max() > 1.0  # a thermostat at ΓΔt = 1 exchanges momentum


def ideal_gas(probability: float) -> Scene:
    """500 non-interacting particles (no [pair]) thermalised at ΓΔt = probability."""
    return Scene.from_dict(
        {
            "seed": 4,
            "precision": "float64",
            "particles": {"density": 3.0, "count": 500},
            "solvent": {
                "method": "lowe_andersen",
                "kT": KT,
                "collision_frequency": probability / DT,
            },
            "integrator": {"dt": DT},
            "output": {"observables": ["temperature"]},
        }
    )


# Long statistical validation (1800 steps per probability): -m slow.  The default run
# keeps Lowe–Andersen thermalisation at ΓΔt = 1 on the module fixture: the temperature
# within 0.5 % and Maxwellian relative velocities of thermalised pairs (tests above).
@pytest.mark.slow
@pytest.mark.parametrize("probability", [0.1, 0.5, 1.0])
def test_ideal_gas_relaxes_to_the_maxwell_distribution(probability):
    """Without conservative forces the exact stationary distribution is the
    Maxwell–Boltzmann one for any ΓΔt ≤ 1: each pair update replaces the relative
    normal velocity by a draw from its Maxwell distribution, which leaves the product
    Maxwellian invariant, and free flight changes no velocity.  Start from velocities
    uniform in a cube at k_BT = 2 (far from Maxwellian) and check, on snapshots 1
    time unit apart: Kolmogorov–Smirnov of v/√k_BT against N(0, 1) at significance
    0.1 %, the kurtosis 3 within five standard errors, and ⟨k_BT⟩ = 1 within four
    block-average standard errors (no integration error without forces)."""
    scene = ideal_gas(probability)
    simulation = build(scene)
    state = simulation.init_fn()
    rng = np.random.default_rng(2)
    uniform = rng.uniform(-1.0, 1.0, size=(scene.n_particles, 3)) * np.sqrt(3 * 2 * KT)
    state = state.set(velocities=jnp.asarray(uniform - uniform.mean(axis=0)))
    assert stats.kstest(uniform.ravel() / np.sqrt(KT), "norm").pvalue < 1e-10
    state = driver.run(simulation, state, 300, 100)  # ≫ the relaxation time
    temperatures, snapshots = [], []

    def collect(result):
        temperatures.append(result.series["temperature"])
        snapshots.append(np.asarray(result.state.velocities).ravel())

    driver.run(simulation, state, 1500, 100, on_chunk=collect)
    scaled = np.concatenate(snapshots) / np.sqrt(KT)
    assert stats.kstest(scaled, "norm").pvalue > 1e-3
    fourth = scaled**4
    assert abs(fourth.mean() - 3.0) < 5 * fourth.std() / np.sqrt(len(fourth))
    mean, error = block_average(np.concatenate(temperatures), n_blocks=20)
    assert abs(float(mean) - KT) < 4 * float(error), (float(mean), float(error))


@pytest.mark.slow
@pytest.mark.parametrize("probability", [0.1, 0.5, 1.0])
def test_temperature_within_half_percent_at_dt_001(probability):
    """Thesis §4.3: ⟨k_BT⟩ within 0.5 % at Δt = 0.01 for ΓΔt = 0.1, 0.5 and 1
    (1000 particles, 10⁴ steps; standard errors 0.08 %, 0.04 %, 0.03 % measured,
    required below 0.15 %: a 0.5 % deviation is then ≥ 3.3 standard errors)."""
    _, series, _ = run_fluid(dumbbell_fluid(probability, 1000), 500, 10_000, 500)
    assert_temperature_within_half_percent(series["temperature"], 1.5e-3)
