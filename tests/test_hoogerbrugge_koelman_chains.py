"""Hoogerbrugge–Koelman solvent with bead-spring chains (Schlijper, Hoogerbrugge &
Manke, J. Rheol. 39, 567 (1995)): the beads are fluid particles that also exchange
spring impulses F δt in the collision-and-propagation update.

References: the HK update and the normalisation of W (jaxdpd.thermostats.
hoogerbrugge_koelman); Hookean free spring ⟨Q²⟩ = 3 k_BT/H (thesis eq. 2.25, Bird
et al. vol. 2); momentum conservation of pair impulses with symmetric noise.
"""

import numpy as np
import pytest

from jaxdpd.analysis.statistics import ratio_of_means
from jaxdpd.engine import errors
from jaxdpd.engine.build import build
from jaxdpd.engine.errors import SimulationError
from jaxdpd.observables import reduce_samples
from jaxdpd.run import driver
from jaxdpd.run.runner import simulate
from jaxdpd.scene import Scene
from jaxdpd.solvents.hoogerbrugge_koelman import HOOGERBRUGGE_KOELMAN_KT

WEAK = {"law": "hookean", "spring_constant": 0.006}  # Schlijper et al.'s weak spring
STRONG = {"law": "fraenkel", "spring_constant": 0.25, "rest_length": 0.85}


def hk_scene(length, count, chained, beads, bond, solvent=None, **sections):
    """A cubic HK box of edge `length` with `chained` beads in chains of `beads`."""
    data = {
        "seed": 11,
        "precision": "float64",
        "box": {"lengths": [length] * 3},
        "particles": {
            "count": count,
            "species": [{"name": "P", "count": chained}, {"name": "S", "count": count - chained}],
        },
        "solvent": {"method": "hoogerbrugge_koelman", **(solvent or {})},
        "polymers": [{"species": "P", "beads": beads, "bond": bond}],
        "neighbors": {"method": "all_pairs"},
        "output": {"observables": ["temperature", "conformation"]},
        **sections,
    }
    return Scene.from_dict(data)


def test_scene_accepts_chains_round_trips_and_starts_cold():
    """Defaults: weight density N/V (left unresolved), initial_kT the default fluid's
    own temperature; the Hookean spring is placed at √(3 initial_kT/H) (not at
    √(3/0.006) ≈ 22 r_c for k_BT = 1) and the velocities start at initial_kT (the
    mean of m v²/3 over 3N − 3 degrees of freedom has relative error √(2/(3N)))."""
    scene = hk_scene(4.0, 192, 40, 2, WEAK)
    assert scene.solvent.weight_density is None
    assert scene.solvent.kT == HOOGERBRUGGE_KOELMAN_KT
    assert Scene.from_dict(scene.to_dict()) == scene
    state = build(scene).init_fn()
    springs = np.diff(np.asarray(state.positions[:40]).reshape(20, 2, 3), axis=1)
    springs += np.diff(np.asarray(state.image[:40]).reshape(20, 2, 3), axis=1) * 4.0
    np.testing.assert_allclose(
        np.linalg.norm(springs, axis=-1), np.sqrt(3 * HOOGERBRUGGE_KOELMAN_KT / 0.006)
    )
    kinetic = np.sum(np.asarray(state.velocities) ** 2) / (3 * 192 - 3)
    assert abs(kinetic / HOOGERBRUGGE_KOELMAN_KT - 1) < 4 * np.sqrt(2 / (3 * 192))
    assert int(state.flags) == 0


def test_spring_impulse_is_force_times_dt():
    """Two beads 1.22 apart (beyond r_c = 1: no collision) in an otherwise empty box:
    one update at δt = 0.5 changes each velocity by δt H Q and moves it by δt v
    (Schlijper et al. 1995, the spring impulse F δt)."""
    bond = {"law": "hookean", "spring_constant": 0.002}
    scene = hk_scene(3.0, 2, 2, 2, bond, solvent={"initial_kT": 0.001}, integrator={"dt": 0.5})
    simulation = build(scene)
    state = simulation.init_fn()
    start = np.asarray(simulation.box.unwrap(state.positions, state.image))
    spring = start[1] - start[0]
    assert np.linalg.norm(spring) == pytest.approx(np.sqrt(3 * 0.001 / 0.002))
    after, _, _ = driver.run_chunk(simulation, state, 1)
    expected = np.asarray(state.velocities) + 0.5 * 0.002 * np.stack([spring, -spring])
    np.testing.assert_allclose(after.velocities, expected, rtol=1e-12, atol=1e-15)
    moved = np.asarray(simulation.box.unwrap(after.positions, after.image))
    np.testing.assert_allclose(moved, start + 0.5 * expected, rtol=1e-12)


def test_weight_density_scales_the_collision():
    """W(r) = 3(1 − r/r_c)/(π n r_c³) and Ω_ij ∝ W: from one start, the first
    collision's velocity change at n = 2 N/V is half that at the default n = N/V."""
    changes = []
    for factor in (1.0, 2.0):
        scene = hk_scene(3.0, 81, 2, 2, WEAK, solvent={"weight_density": factor * 3.0})
        simulation = build(scene)
        state = simulation.init_fn()
        after, _, _ = driver.run_chunk(simulation, state, 1)
        unwrapped = np.asarray(simulation.box.unwrap(state.positions, state.image))
        spring_impulse = np.zeros((81, 3))  # δt H Q, the same at both n
        spring_impulse[:2] = 0.006 * (unwrapped[1] - unwrapped[0]) * np.asarray([[1.0], [-1.0]])
        changes.append(np.asarray(after.velocities - state.velocities) - spring_impulse)
    np.testing.assert_allclose(changes[1], 0.5 * changes[0], rtol=1e-10, atol=1e-14)


def test_runaway_is_measured_against_initial_kT():
    """The runaway check (errors.RUNAWAY_FACTOR × 3 N k_BT) uses initial_kT: a start
    at 10⁻⁶ heats to the fluid's own ≈ 0.0016 (1600×) and stops with a message,
    while the default start runs clean."""
    cold = hk_scene(4.0, 192, 40, 2, WEAK, solvent={"initial_kT": 1e-6})
    simulation = build(cold)
    with pytest.raises(SimulationError, match="initial_kT") as raised:
        driver.run(simulation, simulation.init_fn(), 50, 50)
    assert errors.StepError.TEMPERATURE_RUNAWAY.message in str(raised.value)
    default = build(hk_scene(4.0, 192, 40, 2, WEAK))
    assert int(driver.run(default, default.init_fn(), 50, 50).flags) == 0


def run_series(scene, steps, equilibration):
    """(final state, series) of `steps` steps after `equilibration` (jaxdpd.run.driver)."""
    simulation = build(scene)
    state = driver.run(simulation, simulation.init_fn(), equilibration, equilibration)
    state, samples, _ = driver.run_chunk(simulation, state, steps)
    return state, reduce_samples(samples, scene)


def test_dumbbells_near_equipartition_at_the_measured_temperature():
    """20 Hookean dumbbells (H = 0.006) in an HK fluid of n = 3 (box 4³, 192
    particles): ⟨Q²⟩ against 3 k_BT/H at the fluid's measured kinetic temperature
    (equipartition; Brownian dynamics of the same spring gives it exactly).

    The HK model has no exact canonical reference: its collision rule violates
    fluctuation–dissipation (noise and friction both ∝ W instead of W and W²;
    Español & Warren, Europhys. Lett. 30, 191 (1995)), so neighbouring velocities
    are correlated, and the bonded beads also interact through the fluid (their own
    Π0 repulsion and the fluid's potential of mean force).  A 20 000
    step run of this scene (benchmarks/hk_chains.py reports the same quantity)
    measured H⟨Q²⟩/(3 k_BT) = 0.932 ± 0.006, 7 % below equipartition.  The test
    therefore allows 10 % beyond 3 block-average standard errors: it catches the
    errors this module guards against (a spring impulse without δt, chains placed
    for k_BT = 1, a wrong weight density move the ratio by far more), not the
    model's own few per cent."""
    scene = hk_scene(4.0, 192, 40, 2, WEAK)
    _, series = run_series(scene, 4000, 500)
    ratio, error = ratio_of_means(
        series["P/bond_length_sq"] * WEAK["spring_constant"] / 3, series["temperature"]
    )
    assert abs(float(ratio) - 1) < 0.10 + 3 * float(error), (float(ratio), float(error))
    assert abs(float(np.mean(series["temperature"])) / HOOGERBRUGGE_KOELMAN_KT - 1) < 0.05


def test_trimer_in_a_box_of_edge_2_2_conserves_momentum_with_springs_past_half_box():
    """One Hookean trimer among 32 particles in a box of edge 2.2 (n = 3 fixed, N/V =
    3.005; Schlijper et al.'s smallest boxes): 2000 updates with springs read from the
    image counters run without any error flag, every spring stays finite, some spring
    reaches past half the box edge along an axis (which used to stop the run), and the
    total momentum is conserved to float64 round-off (pair impulses antisymmetric,
    spring impulses equal and opposite)."""
    scene = hk_scene(2.2, 32, 3, 3, WEAK, solvent={"weight_density": 3.0})
    simulation = build(scene)
    state = simulation.init_fn()
    initial = np.asarray(state.velocities).sum(axis=0)
    longest = 0.0
    for _ in range(20):
        state, _, _ = driver.run_chunk(simulation, state, 100)
        unwrapped = np.asarray(simulation.box.unwrap(state.positions, state.image))
        springs = np.diff(unwrapped[:3], axis=0)
        assert np.all(np.isfinite(springs))
        longest = max(longest, float(np.abs(springs).max()))
    assert longest > 1.1, longest
    assert int(state.flags) == 0
    drift = np.abs(np.asarray(state.velocities).sum(axis=0) - initial).max()
    assert drift < 1e-12 * np.abs(np.asarray(state.velocities)).sum()


def test_run_summary_references_use_the_measured_temperature():
    """The summary's ideal-chain reference ⟨Q²⟩ = 3 k_BT/H (Hookean free spring) of an
    HK scene is taken at the measured mean kinetic temperature, not at initial_kT."""
    scene = hk_scene(4.0, 192, 40, 2, WEAK, run={"steps": 200, "chunk": 100})
    summary = simulate(scene, progress=False)
    measured, _ = summary.averages["temperature"]
    assert summary.references["P/bond_length_sq"] == pytest.approx(3 * measured / 0.006)
