"""Exact invariants of the composed DPD steps (thesis §2.1; DESIGN.md "Tests")."""

import jax
import numpy as np
import pytest
from conftest import make_scene, scene_dict

from jaxdpd.engine.build import build
from jaxdpd.forces.pair_laws import soft_repulsion_energy
from jaxdpd.run import driver
from jaxdpd.scene import Scene


def advance(scene, steps, chunk=None):
    simulation = build(scene)
    state = simulation.init_fn()
    return simulation, driver.run(simulation, state, steps, chunk or steps)


TWO_MASSES = [{"name": "light", "count": 300}, {"name": "heavy", "count": 300, "mass": 4.0}]


@pytest.mark.parametrize(
    "solvent, species",
    [
        ({"method": "dpd", "kT": 1.0, "gamma": 4.5}, None),
        ({"method": "dpd", "kT": 1.0, "gamma": 4.5}, TWO_MASSES),
        ({"method": "hoogerbrugge_koelman"}, None),
    ],
)
def test_total_momentum_is_conserved_to_round_off(solvent, species):
    """Pair forces (impulses) are antisymmetric with symmetric noise, so Σ m v is
    constant (also with unequal masses); float64 round-off over 1000 steps stays far
    below 1e-10 of Σ|m v|."""
    data = scene_dict()
    data["solvent"] = solvent
    if species is not None:
        data["particles"] = {**data["particles"], "species": species}
    if solvent["method"] == "hoogerbrugge_koelman":
        del data["pair"]
        data["integrator"] = {"dt": 1.0}
    scene = Scene.from_dict(data)
    simulation = build(scene)
    masses = np.ones(scene.n_particles)
    if simulation.masses is not None:
        masses = np.asarray(simulation.masses)
    state = simulation.init_fn()
    initial = masses @ np.asarray(state.velocities)
    final_state = driver.run(simulation, state, 1000, 250)
    momenta = masses[:, None] * np.asarray(final_state.velocities)
    scale = np.abs(momenta).sum()
    drift = np.abs(momenta.sum(axis=0) - initial).max()
    assert drift <= 1e-10 * scale, (drift, scale)
    assert int(final_state.pair_list.rebuilds) > 0  # the list really was refreshed


def total_energy(state, box_lengths, a, cutoff=1.0):
    """Kinetic plus soft-repulsion potential energy by brute force over all pairs."""
    positions = np.asarray(state.positions)
    lengths = np.asarray(box_lengths)
    d = positions[:, None, :] - positions[None, :, :]
    d -= lengths * np.round(d / lengths)
    r = np.linalg.norm(d, axis=-1)
    upper = np.triu(np.ones_like(r, bool), 1)
    potential = np.sum(np.asarray(soft_repulsion_energy(r[upper], a, cutoff)))
    return 0.5 * np.sum(np.asarray(state.velocities) ** 2) + potential


def test_thermostat_off_conserves_energy_to_second_order_in_dt():
    """γ = σ = 0: velocity Verlet (λ plays no role) conserves energy up to an
    O(Δt²) bounded error.  Halving Δt over the same time must shrink the largest
    energy deviation by 4 (accept 3–5.3: the force's kink at r_c adds
    higher-order terms) and the deviation must be small."""
    deviations, start = {}, None
    for dt in (0.02, 0.01):
        scene = make_scene(solvent={"gamma": 0.0}, integrator={"dt": dt}, particles={"count": 400})
        simulation = build(scene)
        if start is None:
            # Both Δt start from one relaxed, not random, configuration.
            start = driver.run(simulation, simulation.init_fn(), 1, 1)
        state = start.set(time=start.time * 0)
        energies = [total_energy(state, scene.box.lengths, 25.0)]
        steps_per_sample = round(0.1 / dt)
        for _ in range(12):
            state = driver.run(simulation, state, steps_per_sample, steps_per_sample)
            energies.append(total_energy(state, scene.box.lengths, 25.0))
        energies = np.asarray(energies)
        deviations[dt] = np.abs(energies - energies[0]).max() / abs(energies[0])
    ratio = deviations[0.02] / deviations[0.01]
    assert 3.0 < ratio < 5.3, deviations
    assert deviations[0.01] < 1e-3


def test_same_seed_gives_a_bit_identical_trajectory():
    scene = make_scene()
    _, first = advance(scene, 60, 20)
    _, second = advance(scene, 60, 20)
    for name in ("positions", "velocities", "forces", "image"):
        np.testing.assert_array_equal(getattr(first, name), getattr(second, name))
    simulation = build(scene)
    reseeded = simulation.init_fn().set(seed=jax.numpy.asarray(8, jax.numpy.uint32))
    other = driver.run(simulation, reseeded, 60, 20)
    assert not np.array_equal(first.positions, other.positions)


def test_neighbour_list_formats_give_the_same_trajectory():
    """Noise depends on (seed, step, i, j) only, so the cell list (a half list) and
    jax-md's dense and sparse (full) lists give one trajectory up to float64 summation
    order (chaos amplifies ~1e-16 differences; 30 steps keep them ≪ 1e-8)."""
    reference = None
    for neighbors in (
        {"method": "cell_list"},
        {"method": "jax_md", "format": "dense", "skin": 0.3},
        {"method": "jax_md", "format": "sparse", "skin": 0.3},
    ):
        scene = make_scene(neighbors=neighbors, particles={"count": 700})
        _, state = advance(scene, 30, 30)
        positions = np.asarray(state.positions) + np.asarray(state.image) * 6.0
        if reference is None:
            reference = positions
        else:
            np.testing.assert_allclose(positions, reference, atol=1e-8)


def test_vmapped_steps_equal_a_loop_of_steps():
    """vmap over replicas (different seeds) equals stepping each replica alone."""
    scene = make_scene()
    simulation = build(scene)
    base = simulation.init_fn()
    seeds = np.array([1, 2, 3], np.uint32)
    states = [base.set(seed=jax.numpy.asarray(s)) for s in seeds]
    batched = jax.tree_util.tree_map(lambda *xs: jax.numpy.stack(xs), *states)
    step = jax.jit(lambda s: simulation.step_fn(s)[0])
    batched_after = jax.jit(jax.vmap(lambda s: simulation.step_fn(s)[0]))(batched)
    for k, state in enumerate(states):
        single = step(state)
        np.testing.assert_allclose(batched_after.positions[k], single.positions, rtol=0, atol=1e-13)
        np.testing.assert_allclose(
            batched_after.velocities[k], single.velocities, rtol=0, atol=1e-13
        )
