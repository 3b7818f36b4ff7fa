"""`build(scene)`: compose a pure step function from exactly the terms a scene names.

Nothing the scene does not ask for is traced: without a [pair] section there is no
conservative force, with γ = 0 no dissipative or random force, without "pressure"
no virial, and with no pair term at all no neighbour search.
"""

import functools
from collections.abc import Callable
from dataclasses import dataclass

import jax
import jax.numpy as jnp

from jaxdpd import noise
from jaxdpd.boxes import PeriodicBox
from jaxdpd.integrators import collide_and_stream, modified_velocity_verlet
from jaxdpd.neighbors import NeighborSearch, PairList, neighbor_search
from jaxdpd.observables.thermo import step_samples
from jaxdpd.pairs import soft_repulsion_term
from jaxdpd.pairwise import accumulate, pair_geometry
from jaxdpd.scene import Scene
from jaxdpd.state import SimState
from jaxdpd.thermostats.dpd import groot_warren_term
from jaxdpd.thermostats.hoogerbrugge_koelman import hoogerbrugge_koelman_term


@dataclass(frozen=True)
class PairContext:
    """Per-particle data a pair term may read."""

    velocities: jnp.ndarray
    species: jnp.ndarray
    key: jnp.ndarray


@dataclass(frozen=True)
class Simulation:
    """A built scene.

    Attributes:
        scene: the scene it was built from.
        box: the periodic box.
        dtype: floating dtype of positions, velocities and forces.
        neighbor_search: the neighbour backend (None when no pair term exists).
        init_fn: `init_fn() -> SimState`, the initial state of the scene's seed.
        step_fn: `step_fn(state) -> (state, samples)`, pure and jittable; samples is
            a dict of per-step arrays (kinetic and virial tensors as requested).
        reallocate: `reallocate(state, (pairs, cell_occupancy)) -> state` with
            neighbour buffers re-sized from the state's positions to hold at least
            the given needs (host side, after an overflow).
    """

    scene: Scene
    box: PeriodicBox
    dtype: object
    neighbor_search: NeighborSearch | None
    init_fn: Callable
    step_fn: Callable
    reallocate: Callable


def pair_terms(scene: Scene, dtype) -> list:
    """The pair laws the scene names, in the order they are summed."""
    terms = []
    solvent = scene.solvent
    if scene.pair is not None:
        terms.append(soft_repulsion_term(scene.pair.a, dtype))
    if solvent.method == "dpd" and solvent.gamma > 0:
        terms.append(
            groot_warren_term(solvent.gamma, solvent.kT, scene.integrator.dt, solvent.noise, dtype)
        )
    if solvent.method == "hoogerbrugge_koelman":
        terms.append(
            hoogerbrugge_koelman_term(
                scene.particles.density,
                scene.cutoff,
                solvent.pi0,
                solvent.omega,
                solvent.delta_pi,
                1.0,
                dtype,
            )
        )
    return terms


@functools.lru_cache(maxsize=16)
def build(scene: Scene) -> Simulation:
    """Compose the scene's simulation (see the module docstring).

    Cached per scene, so building an equal scene again reuses the compiled chunks.
    """
    dtype = jnp.dtype(scene.precision)
    box = PeriodicBox(tuple(scene.box.lengths))
    n = scene.n_particles
    terms = pair_terms(scene, dtype)
    with_virial = "pressure" in scene.output.observables
    search = None
    if terms:
        search = neighbor_search(
            box,
            n,
            scene.cutoff,
            scene.neighbors.skin,
            scene.neighbors.method,
            scene.neighbors.format,
        )

    def interactions(positions, velocities, state):
        """Σ of the pair terms: per-particle vectors, virial, refreshed pair list."""
        if not terms:
            zeros = jnp.zeros_like(positions)
            return zeros, jnp.zeros((3, 3), dtype), state.pair_list
        pair_list = search.update(positions, state.pair_list)
        geometry = pair_geometry(box, positions, pair_list, scene.cutoff, search.half)
        key = noise.step_key(state.seed, state.step)
        context = PairContext(velocities, state.species, key)
        magnitude = sum(term(geometry, context) for term in terms)
        vectors, virial = accumulate(geometry, magnitude, with_virial)
        if virial is None:
            virial = jnp.zeros((3, 3), dtype)
        return vectors, virial, pair_list

    if scene.solvent.method == "hoogerbrugge_koelman":
        advance = collide_and_stream(box, scene.integrator.dt, interactions, 1.0, dtype)
    else:
        advance = modified_velocity_verlet(
            box,
            scene.integrator.dt,
            scene.integrator.lambda_,
            interactions,
            scene.solvent.kT,
            dtype,
        )

    observables = scene.output.observables

    def step_fn(state):
        state = advance(state)
        return state, step_samples(observables, state)

    def allocate_pairs(positions, minimum=None):
        if search is None:
            return _empty_pair_list(positions)
        return search.allocate(positions, scene.neighbors.capacity_multiplier, minimum)

    def init_fn():
        positions, velocities, species = initial_configuration(scene, box, dtype)
        state = SimState(
            positions=positions,
            velocities=velocities,
            forces=jnp.zeros_like(positions),
            image=jnp.zeros((n, 3), jnp.int32),
            species=species,
            pair_list=allocate_pairs(positions),
            virial=jnp.zeros((3, 3), dtype),
            step=jnp.asarray(0, jnp.int32),
            time=jnp.asarray(0.0, dtype),
            seed=jnp.asarray(scene.seed, jnp.uint32),
            flags=jnp.asarray(0, jnp.int32),
        )
        if scene.solvent.method == "dpd":
            forces, virial, pair_list = jax.jit(interactions)(positions, velocities, state)
            state = state.set(forces=forces, virial=virial, pair_list=pair_list)
        return state

    def reallocate(state, minimum):
        return state.set(pair_list=allocate_pairs(state.positions, minimum))

    return Simulation(scene, box, dtype, search, init_fn, step_fn, reallocate)


def initial_configuration(scene: Scene, box: PeriodicBox, dtype):
    """Uniformly random positions, Maxwell–Boltzmann velocities with zero total
    momentum (k_BT of the solvent, 1 for Hoogerbrugge–Koelman), species in blocks.

    Returns:
        positions (N, 3), velocities (N, 3), species (N,) int32.
    """
    n = scene.n_particles
    key_positions, key_velocities = jax.random.split(jax.random.PRNGKey(scene.seed))
    lengths = box.lengths_array(dtype)
    positions = jax.random.uniform(key_positions, (n, 3), dtype) * lengths
    positions, _ = box.wrap(positions, jnp.zeros((n, 3), jnp.int32))
    kT = scene.solvent.kT if scene.solvent.method == "dpd" else 1.0
    velocities = jax.random.normal(key_velocities, (n, 3), dtype) * jnp.sqrt(jnp.asarray(kT, dtype))
    velocities = velocities - jnp.mean(velocities, axis=0)
    counts = [s.count for s in scene.particles.species]
    species = jnp.repeat(
        jnp.arange(len(counts), dtype=jnp.int32), jnp.asarray(counts), total_repeat_length=n
    )
    return positions, velocities, species


def _empty_pair_list(positions):
    """A one-slot, never-refreshed pair list for scenes without pair terms."""
    n = positions.shape[0]
    empty = jnp.full((1,), n, jnp.int32)
    zero = jnp.asarray(0, jnp.int32)
    return PairList(empty, empty, positions, zero, zero, jnp.asarray(False), zero)
