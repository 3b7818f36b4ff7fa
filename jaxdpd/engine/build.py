"""`build(scene)`: compose a pure step function from exactly the terms a scene names.

Nothing the scene does not ask for is traced: without a [pair] section there is no
conservative force, with γ = 0 no dissipative or random force, with Lowe–Andersen
Γ = 0 no thermalisation, without an observable that needs it ("pressure") no
virial, without [[polymers]] no bond kernel, without [body_force] no external force,
with no pair term or thermostat at all no neighbour search, in a box at rest (no
[flow]) no flow arithmetic, and without [spring_repulsion] or the "spring_pairs"
observable no spring-pair list.
The solvent method's component (jaxdpd.solvents.SOLVENTS) adds its pair terms, the
reach of a pair thermostat, the range of particles that feel forces (e.g. only the
monomers of an MPCD solvent: the force kernel and its neighbour search cover them
alone), its state beside the particles (SimState.solvent_state) and the step itself.
After the solvent's step, each observable the scene lists samples the state
(jaxdpd.observables.component), in registration order.

The bond constants and the body-force amplitude are read from
`SimState.parameters` (jaxdpd.engine.parameters): one compiled step serves every value.
"""

import dataclasses
import functools
from collections.abc import Callable
from dataclasses import dataclass

import jax
import jax.numpy as jnp

from jaxdpd.engine import errors, noise
from jaxdpd.engine.buffers import NeighborBuffers
from jaxdpd.engine.parameters import scene_parameters
from jaxdpd.engine.state import SimState
from jaxdpd.forces.body_forces import cosine_body_force, tagged_body_force
from jaxdpd.forces.bonds import chain_bond_forces
from jaxdpd.forces.pair_laws import PAIR_LAWS
from jaxdpd.forces.pair_sums import pair_geometry, pair_sums
from jaxdpd.forces.spring_repulsion import (
    pair_magnitudes,
    segment_forces,
    segment_virial,
    spring_repulsion_law,
    spring_table,
)
from jaxdpd.geometry.boxes import make_box
from jaxdpd.geometry.chain_topology import chain_blocks
from jaxdpd.geometry.neighbors import NeighborSearch, neighbor_search
from jaxdpd.geometry.neighbors.spring_pair_list import (
    SpringPairSearch,
    free_spring_length,
)
from jaxdpd.geometry.placement import initial_configuration
from jaxdpd.observables import initial_observers, scene_observables
from jaxdpd.observables.component import BuildContext
from jaxdpd.precision import enable_float64
from jaxdpd.run.resources import check_resources
from jaxdpd.scene import Scene
from jaxdpd.solvents import StepContext


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
        box: the static box (jaxdpd.geometry.boxes; bind it to a state's box_state).
        blocks: the polymer chain blocks (jaxdpd.geometry.chain_topology.ChainBlock), maybe empty.
        dtype: floating dtype of positions, velocities and forces.
        masses: (N,) particle masses, or None when all are 1.
        neighbor_search: the neighbour backend (None when no pair term exists).
        spring_search: the spring-pair list's builder (None when nothing reads spring
            pairs).
        init_fn: `init_fn(positions=None, velocities=None) -> SimState`, the initial
            state of the scene's seed, or of the (N, 3) positions (any periodic image,
            chains unbroken) and velocities given (jaxdpd.geometry.placement).
        step_fn: `step_fn(state) -> (state, samples)`, pure and jittable; samples is
            a dict of per-step arrays (kinetic and virial tensors as requested).
        reallocate: `reallocate(state, needs) -> state` with neighbour buffers
            re-sized from the state's positions to hold at least `needs` (host side,
            after an overflow), a tuple as `buffer_needs` gives it (the particle
            list's (pairs, cell occupancy) first), or None to fit the state alone.
        buffer_needs: `buffer_needs(state) -> tuple` of NumPy values: what every
            neighbour buffer needed (for a batch of replicas, arrays over them;
            `reallocate` takes their largest).
        buffer_shapes: `buffer_shapes(state) -> tuple`: the static buffer sizes that
            replicas must share to be stacked.
        fitted_shapes: `fitted_shapes(state) -> tuple`: the sizes `reallocate(state,
            None)` would give, in `buffer_shapes`' order, found without building
            (the driver shrinks buffers that have grown far larger than this).
        init_observers: `init_observers(state) -> state` with empty on-device
            accumulators (`state.observers`), e.g. to discard the equilibration.
    """

    scene: Scene
    box: object
    blocks: tuple
    dtype: object
    masses: object
    neighbor_search: NeighborSearch | None
    spring_search: SpringPairSearch | None
    init_fn: Callable
    step_fn: Callable
    reallocate: Callable
    init_observers: Callable
    buffer_needs: Callable
    buffer_shapes: Callable
    fitted_shapes: Callable


def pair_terms(scene: Scene, dtype) -> list:
    """The pair laws the scene names, in the order they are summed: the [pair] law,
    then the solvent method's terms."""
    terms = []
    if scene.pair is not None:
        terms.append(PAIR_LAWS.get(scene.pair.kind).term(scene.pair, dtype))
    terms.extend(scene.solvent_component.pair_terms(scene, dtype))
    return terms


def pair_term_parts(terms, geometry, velocities, state) -> dict:
    """{part: (P,) magnitudes} of the pair terms over the pairs of `geometry`, with
    the velocities given, the state's species and the step's noise key."""
    context = PairContext(velocities, state.species, noise.step_key(state.seed, state.step))
    parts = {}
    for term in terms:
        parts.update(term(geometry, context))
    return parts


def body_force_law(scene: Scene, dtype):
    """`force(positions, amplitude)` of the scene's [body_force], or None."""
    section = scene.body_force
    if section is None:
        return None
    if section.kind == "cosine":
        return cosine_body_force(section.waves, scene.box.lengths[1], dtype)
    first, count = scene.species_range(section.species)
    return tagged_body_force(first, count, scene.n_particles, dtype)


def force_kernel(
    box,
    terms,
    search,
    blocks,
    cutoff: float,
    with_virial: bool,
    body_force,
    spring_search=None,
    repulsion=None,
):
    """The composed force kernel: the pair terms, the body force and the springs of
    every chain block.

    It acts on one contiguous range of particles: all of them, or the monomers of an
    MPCD scene (then the positions and state it is given hold those rows only, the
    neighbour search covers them alone and `blocks` index within the range).

    Args:
        box: the static box (bound to each state's box_state).
        terms: pair terms (`pair_terms`), maybe empty.
        search: the neighbour backend over the range (None without pair terms or
            thermostat).
        blocks: ChainBlocks indexed within the range.
        cutoff: r_c of the pair terms.
        with_virial: compute the virial parts (else none).
        body_force: `body_force(positions, amplitude) -> (N, 3)` or None.
        spring_search: the spring-pair list (SpringPairSearch), or None.
        repulsion: the spring–spring repulsion law (jaxdpd.forces.spring_repulsion), or None.
    Returns:
        `interactions(positions, velocities, state) -> (vectors, virial parts
        {name: (3, 3)}, the state with its neighbour lists refreshed, error bits)`.
    """

    def spring_interactions(positions, state, vectors, virial):
        """Refresh the spring-pair list; add the spring–spring repulsion if the scene
        has one.  Returns (vectors, virial, refreshed list, overflow bits)."""
        spring_pairs, geometry = spring_search.refresh(
            positions, state.spring_pairs, state.box_state
        )
        bits = jnp.where(spring_pairs.overflow, errors.StepError.NEIGHBOR_OVERFLOW, 0)
        if repulsion is not None:
            magnitude = pair_magnitudes(geometry, repulsion)
            vectors = vectors + segment_forces(geometry, magnitude, positions.shape[0])
            if with_virial:
                virial["spring_repulsion"] = segment_virial(geometry, magnitude)
        return vectors, virial, spring_pairs, bits

    def pair_interactions(bound_box, positions, velocities, state, refresh):
        """Σ of the pair terms: per-particle vectors, virial parts, refreshed pair list."""
        if search is None:
            return jnp.zeros_like(positions), {}, state.pair_list
        pair_list = state.pair_list
        if refresh:
            pair_list = search.update(positions, pair_list, state.box_state)
        if not terms:  # the list serves the thermostat alone
            return jnp.zeros_like(positions), {}, pair_list
        geometry = pair_geometry(bound_box, positions, pair_list, cutoff, search.half)
        parts = pair_term_parts(terms, geometry, velocities, state)
        vectors, virial = pair_sums(geometry, parts, with_virial)
        return vectors, virial, pair_list

    def interactions(positions, velocities, state, refresh_pairs: bool = True):
        """Pair terms plus the springs of every chain block (and their mutual
        repulsion), in the box of `state`.  `refresh_pairs` False reads the pair list
        as it is: for a list just built from these positions (the initial forces),
        which an update would leave unchanged, without tracing the cell list again.

        Returns:
            (per-particle vectors, virial parts {name: (3, 3)}, the state with its
            neighbour lists refreshed, error bits).
        """
        bound_box = box.bind(state.box_state)
        vectors, virial, pair_list = pair_interactions(
            bound_box, positions, velocities, state, refresh_pairs
        )
        state = state.set(pair_list=pair_list)
        if body_force is not None:
            vectors = vectors + body_force(positions, state.parameters["body_force"]["amplitude"])
        bits = jnp.asarray(0, jnp.int32)
        for block in blocks:
            law = block.law.with_parameters(state.parameters["bond"][block.species])
            bonded = chain_bond_forces(
                bound_box,
                block.take(positions),
                block.take(state.image),
                law,
                with_virial,
                half_box_limit=spring_search is not None,
            )
            vectors = vectors.at[block.first : block.stop].add(bonded.forces.reshape(-1, 3))
            if with_virial:
                virial["bond"] = virial.get("bond", 0) + bonded.virial
            bits = (
                bits
                | jnp.where(bonded.overstretched, errors.StepError.SPRING_OVERSTRETCHED, 0)
                | jnp.where(bonded.past_half_box, errors.StepError.SPRING_PAST_HALF_BOX, 0)
            )
        if spring_search is not None:
            vectors, virial, spring_pairs, spring_bits = spring_interactions(
                positions, state, vectors, virial
            )
            state = state.set(spring_pairs=spring_pairs)
            bits = bits | spring_bits
        return vectors, virial, state, bits

    return interactions


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


def pair_search(scene: Scene, box, terms, bath_cutoff, particles: int):
    """The neighbour backend of the pair terms and a pair thermostat over `particles`
    particles, or None when the scene has neither."""
    if not terms and bath_cutoff is None:
        return None
    neighbors = scene.neighbors
    reach = max(scene.cutoff, bath_cutoff or 0.0)
    return neighbor_search(
        box, particles, reach, neighbors.skin, neighbors.method, neighbors.format
    )


def spring_pair_search(scene: Scene, box, blocks) -> SpringPairSearch | None:
    """The spring-pair list's builder, when the scene reads spring pairs."""
    if scene.spring_reach is None:
        return None
    return SpringPairSearch(
        box,
        spring_table(blocks),
        scene.spring_reach,
        scene.neighbors.spring_skin,
        max(free_spring_length(block.law, scene.solvent.kT) for block in blocks),
        scene.neighbors.capacity_multiplier,
    )


@functools.lru_cache(maxsize=16)
def build(scene: Scene) -> Simulation:
    """Compose the scene's simulation (see the module docstring).

    Cached per scene, so building an equal scene again reuses the compiled chunks.
    A scene with parallel.devices > 1 is decomposed over devices
    (jaxdpd.decomposition.simulation.build_decomposed).
    """
    if scene.parallel.devices > 1:
        from jaxdpd.decomposition.simulation import build_decomposed

        return build_decomposed(scene)
    enable_float64()  # any scene: uint64 cell words, int64 keys (jaxdpd.precision)
    dtype = jnp.dtype(scene.precision)
    box = make_box(scene.box.kind, scene.box.lengths, scene.flow)
    check_resources(scene, box)
    solvent = scene.solvent_component
    terms = pair_terms(scene, dtype)
    blocks = chain_blocks(scene)
    first, stop = solvent.force_range(scene, blocks)
    local_blocks = tuple(dataclasses.replace(b, first=b.first - first) for b in blocks)
    observables = scene_observables(scene)
    with_virial = any(component.needs_virial for component in observables)
    masses = particle_masses(scene, dtype)
    search = pair_search(scene, box, terms, solvent.bath_cutoff(scene), stop - first)
    spring_search = spring_pair_search(scene, box, blocks)
    buffers = NeighborBuffers(
        search, spring_search, (first, stop), scene.neighbors.capacity_multiplier
    )
    repulsion = None
    if scene.spring_repulsion is not None:
        repulsion = spring_repulsion_law(scene.spring_repulsion.table())

    interactions = force_kernel(
        box,
        terms,
        search,
        local_blocks,
        scene.cutoff,
        with_virial,
        body_force_law(scene, dtype),
        spring_search,
        repulsion,
    )
    advance = solvent.advance(
        StepContext(scene, box, interactions, masses, (first, stop), search, with_virial, dtype)
    )
    context = BuildContext(scene, box, blocks, masses, dtype, spring_search)
    samplers = [s for s in (c.sampler(context) for c in observables) if s is not None]

    def step_fn(previous):
        state = advance(previous)
        samples = {}
        for sample in samplers:
            state, taken = sample(previous, state)
            samples.update(taken)
        return state, samples

    def init_observers(state):
        return initial_observers(observables, context, state)

    def init_fn(positions=None, velocities=None):
        positions, image, velocities, species = initial_configuration(
            scene, box, dtype, blocks, positions, velocities
        )
        box_state = box.initial_state(dtype)
        state = SimState(
            positions=positions,
            velocities=velocities,
            forces=jnp.zeros_like(positions),
            image=image,
            species=species,
            pair_list=buffers.pair_list(positions, box_state),
            virial={},
            step=jnp.asarray(0, jnp.int32),
            time=jnp.asarray(0.0, dtype),
            seed=jnp.asarray(scene.seed, jnp.uint32),
            flags=jnp.asarray(0, jnp.int32),
            box_state=box_state,
            parameters=scene_parameters(scene, blocks, dtype),
            spring_pairs=buffers.spring_pairs(positions, box_state),
        )
        solvent_state = solvent.initial_solvent_state(scene, dtype)
        if solvent_state is not None:
            state = state.set(solvent_state=solvent_state)
        # Zeros of the virial parts a step records, so the state keeps one structure.
        parts = jax.eval_shape(advance, state).virial
        state = state.set(virial=jax.tree.map(lambda w: jnp.zeros(w.shape, w.dtype), parts))
        state = init_observers(state)
        if stop > first and solvent.initial_forces:
            rows = slice(first, stop)
            sub = state.set(image=image[rows], species=species[rows])
            # The pair list was built from these positions just above: the kernel reads
            # it as it is, so this program does not compile the cell list a second time.
            initial_forces = jax.jit(functools.partial(interactions, refresh_pairs=False))
            forces, virial, refreshed, bits = initial_forces(positions[rows], velocities[rows], sub)
            state = state.set(
                forces=state.forces.at[rows].set(forces),
                virial={**state.virial, **virial},
                pair_list=refreshed.pair_list,
                spring_pairs=refreshed.spring_pairs,
                flags=bits,
            )
        return state

    return Simulation(
        scene,
        box,
        blocks,
        dtype,
        masses,
        search,
        spring_search,
        init_fn,
        step_fn,
        buffers.reallocate,
        init_observers,
        buffers.needs,
        buffers.shapes,
        buffers.fitted_shapes,
    )
