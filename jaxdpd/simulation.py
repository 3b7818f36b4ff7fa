"""`build(scene)`: compose a pure step function from exactly the terms a scene names.

Nothing the scene does not ask for is traced: without a [pair] section there is no
conservative force, with γ = 0 no dissipative or random force, with Lowe–Andersen
Γ = 0 no thermalisation, without "pressure" no virial, without [[polymers]] no bond
kernel, without [body_force] no external force, with no pair term or thermostat at
all no neighbour search, and in a box at rest (no [flow]) no flow arithmetic.  With
solvent.method = "lattice_boltzmann" the particles are beads coupled by friction to
a lattice-Boltzmann fluid kept in SimState.solvent_state (jaxdpd.lattice_boltzmann);
with its k_BT = 0 no noise is traced.
"""

import functools
from collections.abc import Callable
from dataclasses import dataclass

import jax
import jax.numpy as jnp

from jaxdpd import errors, noise
from jaxdpd.bonds import chain_bond_forces
from jaxdpd.boxes import make_box
from jaxdpd.forcing import cosine_body_force
from jaxdpd.integrators import (
    collide_and_stream,
    modified_velocity_verlet,
    thermalized_velocity_verlet,
)
from jaxdpd.lattice_boltzmann import fluid_parameters, md_steps_per_lattice_step
from jaxdpd.lattice_boltzmann.integrator import coupled_step, initial_fluid_state
from jaxdpd.neighbors import NeighborSearch, PairList, neighbor_search
from jaxdpd.observables.chain_correlators import (
    init_chain_correlators,
    sample_every,
    update_chain_correlators,
)
from jaxdpd.observables.chain_series import conformation_samples
from jaxdpd.observables.profiles import profile_samples
from jaxdpd.observables.thermo import step_samples
from jaxdpd.pairs import soft_repulsion_term, wca_term
from jaxdpd.pairwise import accumulate, pair_geometry, pair_virial
from jaxdpd.placement import initial_configuration
from jaxdpd.scene import Scene
from jaxdpd.state import SimState
from jaxdpd.thermostats.dpd import groot_warren_term
from jaxdpd.thermostats.hoogerbrugge_koelman import hoogerbrugge_koelman_term
from jaxdpd.thermostats.lowe_andersen import empty_record, lowe_andersen_thermostat
from jaxdpd.topology import chain_blocks


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
        box: the static box (jaxdpd.boxes; bind it to a state's box_state).
        blocks: the polymer chain blocks (jaxdpd.topology.ChainBlock), maybe empty.
        dtype: floating dtype of positions, velocities and forces.
        masses: (N,) particle masses, or None when all are 1.
        neighbor_search: the neighbour backend (None when no pair term exists).
        init_fn: `init_fn() -> SimState`, the initial state of the scene's seed.
        step_fn: `step_fn(state) -> (state, samples)`, pure and jittable; samples is
            a dict of per-step arrays (kinetic and virial tensors as requested).
        reallocate: `reallocate(state, (pairs, cell_occupancy)) -> state` with
            neighbour buffers re-sized from the state's positions to hold at least
            the given needs (host side, after an overflow).
        init_observers: `init_observers(state) -> state` with empty on-device
            accumulators (`state.observers`), e.g. to discard the equilibration.
    """

    scene: Scene
    box: object
    blocks: tuple
    dtype: object
    masses: object
    neighbor_search: NeighborSearch | None
    init_fn: Callable
    step_fn: Callable
    reallocate: Callable
    init_observers: Callable


def pair_terms(scene: Scene, dtype) -> list:
    """The pair laws the scene names, in the order they are summed."""
    terms = []
    solvent = scene.solvent
    if scene.pair is not None and scene.pair.kind == "wca":
        terms.append(wca_term(scene.pair.epsilon, scene.pair.sigma, dtype))
    elif scene.pair is not None:
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


def particle_masses(scene: Scene, dtype):
    """(N,) particle masses in species order, or None when every mass is 1 (then no
    mass arithmetic is traced)."""
    species = scene.particles.species
    if all(s.mass == 1.0 for s in species):
        return None
    return jnp.repeat(
        jnp.asarray([s.mass for s in species], dtype),
        jnp.asarray([s.count for s in species]),
        total_repeat_length=scene.n_particles,
    )


def thermalization_cutoff(scene: Scene) -> float | None:
    """r_T of an active Lowe–Andersen thermostat (default r_c), else None."""
    solvent = scene.solvent
    if solvent.method != "lowe_andersen" or solvent.collision_frequency == 0:
        return None
    if solvent.thermalization_cutoff is None:
        return scene.cutoff
    return solvent.thermalization_cutoff


@functools.lru_cache(maxsize=16)
def build(scene: Scene) -> Simulation:
    """Compose the scene's simulation (see the module docstring).

    Cached per scene, so building an equal scene again reuses the compiled chunks.
    """
    dtype = jnp.dtype(scene.precision)
    box = make_box(scene.box.kind, scene.box.lengths, scene.flow)
    n = scene.n_particles
    terms = pair_terms(scene, dtype)
    blocks = chain_blocks(scene)
    with_virial = "pressure" in scene.output.observables
    masses = particle_masses(scene, dtype)
    bath_cutoff = thermalization_cutoff(scene)
    body_force = None
    if scene.body_force is not None:
        body_force = cosine_body_force(
            scene.body_force.amplitude, scene.body_force.waves, scene.box.lengths[1], dtype
        )
    search = None
    if terms or bath_cutoff is not None:
        search = neighbor_search(
            box,
            n,
            max(scene.cutoff, bath_cutoff or 0.0),
            scene.neighbors.skin,
            scene.neighbors.method,
            scene.neighbors.format,
        )

    def pair_interactions(bound_box, positions, velocities, state):
        """Σ of the pair terms: per-particle vectors, virial parts, refreshed pair list."""
        if search is None:
            return jnp.zeros_like(positions), {}, state.pair_list
        pair_list = search.update(positions, state.pair_list, state.box_state)
        if not terms:  # the list serves the thermostat alone
            return jnp.zeros_like(positions), {}, pair_list
        geometry = pair_geometry(bound_box, positions, pair_list, scene.cutoff, search.half)
        key = noise.step_key(state.seed, state.step)
        context = PairContext(velocities, state.species, key)
        parts = {}
        for term in terms:
            parts.update(term(geometry, context))
        vectors = accumulate(geometry, sum(parts.values()))
        virial = {}
        if with_virial:
            virial = {name: pair_virial(geometry, m) for name, m in parts.items()}
        return vectors, virial, pair_list

    def interactions(positions, velocities, state):
        """Pair terms plus the springs of every chain block, in the box of `state`.

        Returns:
            (per-particle vectors, virial parts {name: (3, 3)}, refreshed pair list,
            error bits).
        """
        bound_box = box.bind(state.box_state)
        vectors, virial, pair_list = pair_interactions(bound_box, positions, velocities, state)
        if body_force is not None:
            vectors = vectors + body_force(positions)
        bits = jnp.asarray(0, jnp.int32)
        for block in blocks:
            bonded = chain_bond_forces(
                bound_box, block.take(positions), block.take(state.image), block.law, with_virial
            )
            vectors = vectors.at[block.first : block.stop].add(bonded.forces.reshape(-1, 3))
            if with_virial:
                virial["bond"] = virial.get("bond", 0) + bonded.virial
            bits = (
                bits
                | jnp.where(bonded.overstretched, errors.SPRING_OVERSTRETCHED, 0)
                | jnp.where(bonded.past_half_box, errors.SPRING_PAST_HALF_BOX, 0)
            )
        return vectors, virial, pair_list, bits

    fluid = None
    if scene.solvent.method == "hoogerbrugge_koelman":
        advance = collide_and_stream(box, scene.integrator.dt, interactions, 1.0, dtype)
    elif bath_cutoff is not None:
        lowe_andersen = lowe_andersen_thermostat(
            n,
            min(1.0, scene.solvent.collision_frequency * scene.integrator.dt),
            scene.solvent.kT,
            bath_cutoff,
            scene.integrator.dt,
            dtype,
            search.half,
            masses,
            with_virial,
        )

        def thermalize(state, velocities):
            """Thermalise at the state's positions and box; noise keyed by its step."""
            key = noise.step_key(state.seed, state.step)
            bound_box = box.bind(state.box_state)
            return lowe_andersen(bound_box, state.positions, velocities, state.pair_list, key)

        advance = thermalized_velocity_verlet(
            box,
            scene.integrator.dt,
            interactions,
            thermalize,
            scene.solvent.kT,
            dtype,
            masses,
            with_virial,
        )
    elif scene.solvent.method == "lattice_boltzmann":
        fluid = fluid_parameters(scene)
        advance = coupled_step(
            box,
            scene.integrator.dt,
            md_steps_per_lattice_step(scene),
            interactions,
            fluid,
            scene.solvent.friction,
            dtype,
            masses,
            scene.solvent.noise,
        )
    else:
        advance = modified_velocity_verlet(
            box,
            scene.integrator.dt,
            scene.integrator.lambda_,
            interactions,
            scene.solvent.kT,
            dtype,
            masses,
        )

    observables = scene.output.observables

    def step_fn(state):
        state = advance(state)
        samples = step_samples(observables, state, masses)
        bound_box = box.bind(state.box_state)
        if "conformation" in observables:
            samples.update(conformation_samples(bound_box, state.positions, blocks))
        if "profile" in observables:
            samples.update(
                profile_samples(
                    bound_box, state.positions, state.velocities, masses, scene.output.profile_bins
                )
            )
        if "dynamics" in observables:
            observers = sample_every(
                state.step,
                scene.output.correlator_every,
                state.observers,
                lambda c: update_chain_correlators(c, box, state.positions, state.image, blocks),
            )
            state = state.set(observers=observers)
        return state, samples

    def init_observers(state):
        """The state with empty on-device accumulators (e.g. after equilibration)."""
        if "dynamics" not in observables:
            return state
        return state.set(
            observers=init_chain_correlators(
                box, state.positions, state.image, blocks, scene.output.correlator_levels
            )
        )

    def allocate_pairs(positions, box_state, minimum=None):
        if search is None:
            return _empty_pair_list(positions)
        return search.allocate(positions, scene.neighbors.capacity_multiplier, minimum, box_state)

    def init_fn():
        positions, image, velocities, species = initial_configuration(scene, box, dtype, blocks)
        box_state = box.initial_state(dtype)
        state = SimState(
            positions=positions,
            velocities=velocities,
            forces=jnp.zeros_like(positions),
            image=image,
            species=species,
            pair_list=allocate_pairs(positions, box_state),
            virial={},
            step=jnp.asarray(0, jnp.int32),
            time=jnp.asarray(0.0, dtype),
            seed=jnp.asarray(scene.seed, jnp.uint32),
            flags=jnp.asarray(0, jnp.int32),
            box_state=box_state,
        )
        # Zeros of the virial parts a step records, so the state keeps one structure.
        parts = jax.eval_shape(interactions, positions, velocities, state)[1]
        if bath_cutoff is not None and with_virial:
            parts = {**parts, "impulse": jax.ShapeDtypeStruct((3, 3), dtype)}
        state = state.set(virial=jax.tree.map(lambda w: jnp.zeros(w.shape, w.dtype), parts))
        state = init_observers(state)
        if scene.solvent.method != "hoogerbrugge_koelman":
            forces, virial, pair_list, bits = jax.jit(interactions)(positions, velocities, state)
            virial = {**state.virial, **virial}  # keeps the thermostat's "impulse" zeros
            state = state.set(forces=forces, virial=virial, pair_list=pair_list, flags=bits)
        if bath_cutoff is not None:
            state = state.set(solvent_state=empty_record(dtype))
        if fluid is not None:
            state = state.set(solvent_state=initial_fluid_state(fluid, scene.seed, dtype))
        return state

    def reallocate(state, minimum):
        return state.set(pair_list=allocate_pairs(state.positions, state.box_state, minimum))

    return Simulation(
        scene, box, blocks, dtype, masses, search, init_fn, step_fn, reallocate, init_observers
    )


def _empty_pair_list(positions):
    """A one-slot, never-refreshed pair list for scenes without pair terms."""
    n = positions.shape[0]
    empty = jnp.full((1,), n, jnp.int32)
    zero = jnp.asarray(0, jnp.int32)
    return PairList(empty, empty, positions, None, zero, zero, jnp.asarray(False), zero)
