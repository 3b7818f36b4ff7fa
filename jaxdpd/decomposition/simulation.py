"""`build_decomposed(scene)`: one system stepped on D devices, one slab each.

Each step, inside `jax.shard_map` over the devices (mesh axis `DOMAINS`):
1. every device sends copies of its particles within the halo width h of each face
   to the neighbour beyond it (`exchange.shift`), and receives theirs;
2. it runs the solvent's own step (jaxdpd.solvents) on its owned rows and the halo
   copies, with the force kernel of `forces` (pair noise keyed by particle identity,
   bonds found by identity) and the cell list over its `SlabView`.  Halo copies are
   advanced exactly as their owners advance them (same operands, same arithmetic),
   so after the drift every owned particle has all its partners within reach when
   h covers the reach plus the approach within one step (`parallel.margin`);
3. it keeps its owned rows, discards the copies, and hands each particle that left
   its slab to the neighbour that owns it now (`exchange.admit`);
4. sums over the system (kinetic tensor, virial shares, the momentum a flowing box
   removes) are `psum`s over the devices.

The state (`DecomposedState`) holds each device's rows with a leading device axis,
sharded over the mesh.  Buffers have fixed sizes; a device that needs more rows,
halo or migration room than it has raises the neighbour-overflow flag, and the
driver (jaxdpd.run.driver) reallocates and reruns the chunk, as for a neighbour
list.  The step is the same function of the state on every device count, but the
forces on a particle are summed in another order than on one device, so decomposed
and single-device trajectories agree to round-off, which the chaos of the dynamics
then amplifies (docs/scaling_out.md measures both).
"""

import dataclasses
import math

import jax
import jax.numpy as jnp
import numpy as np
from jax.sharding import Mesh, NamedSharding
from jax.sharding import PartitionSpec as P

from jaxdpd import pytree
from jaxdpd.decomposition import exchange
from jaxdpd.decomposition.exchange import DOMAINS, Rows
from jaxdpd.decomposition.forces import domain_force_kernel, identity_lookup
from jaxdpd.decomposition.layout import SlabLayout, buffer_sizes, head_room, slab_axis
from jaxdpd.decomposition.requirements import halo_width
from jaxdpd.decomposition.slab_view import SlabState, SlabView
from jaxdpd.engine import errors
from jaxdpd.engine.build import Simulation, body_force_law, build, pair_terms
from jaxdpd.engine.ownership import Ownership
from jaxdpd.engine.state import SimState
from jaxdpd.geometry.neighbors import PairList
from jaxdpd.geometry.neighbors.cell_list import cell_list_search
from jaxdpd.observables import scene_observables
from jaxdpd.observables.component import BuildContext
from jaxdpd.solvents import StepContext

# The per-particle fields a device's rows carry besides the identities.
PARTICLE_FIELDS = ("positions", "velocities", "forces", "image", "species")


@pytree.dataclass
class DomainNeeds:
    """The largest demands on each device's buffers since they were sized ((D,) int32).

    Attributes:
        rows: particles a device owned (counting any that found no free row).
        halo: copies it sent over one face.
        migrants: particles that left it over one face in one step.
    """

    rows: jnp.ndarray
    halo: jnp.ndarray
    migrants: jnp.ndarray


@pytree.dataclass
class DecomposedState:
    """The state of a decomposed run: per-device rows and the replicated rest.

    Attributes:
        rows: `exchange.Rows` with a leading device axis (D, C, ...).
        pair_list: each device's pair list (leading axis D).
        needs: `DomainNeeds`.
        virial: {part: (3, 3)} the system's virial parts of the last step.
        step, time, seed, flags, box_state, parameters: as in SimState.
        observers: None (no accumulating observable is measured in decomposed runs).
        halo_capacity: static, rows per face for halo copies.
        migration_capacity: static, rows per face for migrating particles.
    """

    rows: Rows
    pair_list: PairList
    needs: DomainNeeds
    virial: dict
    step: jnp.ndarray
    time: jnp.ndarray
    seed: jnp.ndarray
    flags: jnp.ndarray
    box_state: object
    parameters: object
    observers: object = None
    halo_capacity: int = pytree.static_field(default=0)
    migration_capacity: int = pytree.static_field(default=0)

    def particles(self, names=PARTICLE_FIELDS) -> dict:
        """The particles' fields `names` (default all of PARTICLE_FIELDS) as NumPy
        arrays in scene order (host side)."""
        ids = np.asarray(self.rows.ids).reshape(-1)
        present = ids >= 0
        order = np.argsort(ids[present])
        fields = {}
        for name in names:
            values = np.asarray(getattr(self.rows, name))
            fields[name] = values.reshape((ids.size,) + values.shape[2:])[present][order]
        return fields

    # What output writers read of a state (jaxdpd.io.h5md), in scene order.
    positions = property(lambda self: self.particles(("positions",))["positions"])
    velocities = property(lambda self: self.particles(("velocities",))["velocities"])
    image = property(lambda self: self.particles(("image",))["image"])


@dataclasses.dataclass(frozen=True)
class DecomposedSimulation(Simulation):
    """A Simulation whose state is a `DecomposedState` (see the module docstring).

    Extra attributes:
        layout: the SlabLayout the buffers were first sized with.
        mesh: the device mesh (axis `DOMAINS`).
    """

    layout: SlabLayout = None
    mesh: Mesh = None


def _sharded_fields(state):
    """PartitionSpecs of a DecomposedState: device axis on rows, lists and needs."""
    specs = jax.tree.map(lambda _: P(), state)
    per_device = {
        name: jax.tree.map(lambda _: P(DOMAINS), getattr(state, name))
        for name in ("rows", "pair_list", "needs")
    }
    return specs.set(**per_device)


def _frame_coordinate(bound_box, positions, axis: int):
    return bound_box.frame_positions(positions)[:, axis]


def device_mesh(devices: int) -> Mesh:
    """A mesh of the first `devices` devices, or a message saying how to get them."""
    available = jax.devices()
    if len(available) < devices:
        raise ValueError(
            f"parallel.devices = {devices}, but JAX sees {len(available)} "
            f"{available[0].platform} device(s); on CPU set "
            f"XLA_FLAGS=--xla_force_host_platform_device_count={devices} before "
            "JAX is imported"
        )
    return Mesh(np.asarray(available[:devices]), (DOMAINS,))


def build_decomposed(scene) -> DecomposedSimulation:
    """Compose the decomposed step of `scene` (parallel.devices > 1).

    The initial state is the single-device scene's (same seed, same placement,
    same initial forces), dealt out to the slabs.
    """
    serial = build(scene.replace(parallel={"devices": 1}))
    dtype, box = serial.dtype, serial.box
    devices = scene.parallel.devices
    axis = slab_axis(box, scene.parallel.axis)
    halo = halo_width(scene)
    multiplier = scene.neighbors.capacity_multiplier
    width = box.lengths[axis] / devices
    sizes = buffer_sizes(scene.n_particles, devices, width, halo, multiplier)
    layout = SlabLayout(axis, devices, box.lengths[axis], halo, *sizes)
    mesh = device_mesh(devices)
    view = SlabView(box, axis, layout.local_length)
    solvent = scene.solvent_component
    _, reach = solvent.pair_range(scene.solvent, scene.cutoff)
    terms = pair_terms(scene, dtype)
    body_force = body_force_law(scene, dtype)
    observables = scene_observables(scene)
    with_virial = any(component.needs_virial for component in observables)
    context = BuildContext(scene, box, serial.blocks, None, dtype, None)
    samplers = [s for s in (c.domain_sampler(context) for c in observables) if s is not None]
    check_drift = solvent.decomposition == "forces_after_drift"
    kT = scene.solvent.kT
    density = scene.n_particles / box.volume

    def step_on_device(state, search):
        capacity = state.rows.ids.shape[1]
        halo_capacity, migration_capacity = state.halo_capacity, state.migration_capacity
        k = jax.lax.axis_index(DOMAINS)
        rows = jax.tree.map(lambda leaf: leaf[0], state.rows)
        pair_list = jax.tree.map(lambda leaf: leaf[0], state.pair_list)
        needs = jax.tree.map(lambda leaf: leaf[0], state.needs)
        bound = box.bind(state.box_state)
        origin = layout.view_origin(k, dtype)
        along = layout.view_coordinate(_frame_coordinate(bound, rows.positions, axis), k)
        local, sent, route = exchange.with_halos(rows, along, width, halo, halo_capacity, devices)
        owned = jnp.concatenate([rows.present, jnp.zeros(2 * halo_capacity, bool)])
        row_of = identity_lookup(local.ids)
        ownership = Ownership(
            owned,
            lambda x: jax.lax.psum(x, DOMAINS),
            local.ids,
            lambda wanted: row_of(wanted)[0],
            route.resend,
        )
        local_state = SimState(
            positions=local.positions,
            velocities=local.velocities,
            forces=local.forces,
            image=local.image,
            species=local.species,
            pair_list=pair_list,
            virial=state.virial,
            step=state.step,
            time=state.time,
            seed=state.seed,
            flags=jnp.asarray(0, jnp.int32),
            box_state=state.box_state,
            parameters=state.parameters,
        )
        rows_stepped = local.ids.shape[0]
        advance = solvent.advance(
            StepContext(
                scene,
                box,
                domain_force_kernel(
                    box, search, terms, serial.blocks, scene.cutoff, with_virial, body_force, halo
                )(local.ids, owned, origin, row_of),
                None,
                (0, rows_stepped),
                search,
                with_virial,
                dtype,
                ownership,
            )
        )
        new = advance(local_state)
        stepped = exchange.release(
            Rows(
                ids=rows.ids,
                positions=new.positions[:capacity],
                velocities=new.velocities[:capacity],
                forces=new.forces[:capacity],
                image=new.image[:capacity],
                species=rows.species,
            ),
            ~rows.present,
        )
        bits = new.flags & ~(errors.StepError.NON_FINITE | errors.StepError.TEMPERATURE_RUNAWAY)
        new_bound = box.bind(new.box_state)
        if check_drift:
            # A particle outside the halo was more than h from the slab along the
            # axis; it can come within reach of an owned one only if the two
            # approached by more than the margin along the axis in this step.
            moved = new_bound.minimum_image_vectors(stepped.positions - rows.positions)
            approach = jnp.where(rows.present, jnp.abs(moved[:, axis]), 0)
            too_far = jnp.max(approach) > 0.5 * scene.parallel.margin
            bits = bits | jnp.where(too_far, errors.StepError.DOMAIN_REACH, 0)
        # Hand over the particles that left the slab.
        owner = layout.owner(_frame_coordinate(new_bound, stepped.positions, axis))
        kept, migrants, homeless, skipped = exchange.hand_over(
            stepped, owner, k, devices, migration_capacity
        )
        held = jnp.sum(kept.present, dtype=jnp.int32) + homeless
        overflow = (sent > halo_capacity) | (migrants > migration_capacity) | (homeless > 0)
        bits = (
            bits
            | jnp.where(overflow, errors.StepError.NEIGHBOR_OVERFLOW, 0)
            | jnp.where(skipped, errors.StepError.DOMAIN_REACH, 0)
        )
        # Sums over the system.
        velocities = new.velocities
        twice_kinetic = ownership.system_sum(jnp.sum(velocities * velocities, axis=1))
        position_sum = ownership.system_sum(jnp.sum(new.positions, axis=1))
        system_bits = jnp.where(
            jnp.isfinite(position_sum + twice_kinetic), 0, errors.StepError.NON_FINITE
        ) | jnp.where(
            twice_kinetic > errors.RUNAWAY_FACTOR * 3 * kT * scene.n_particles,
            errors.StepError.TEMPERATURE_RUNAWAY,
            0,
        )
        every_bits = jax.lax.all_gather(bits, DOMAINS)
        bits = jax.lax.reduce(every_bits, jnp.int32(0), jax.lax.bitwise_or, (0,)) | system_bits
        samples = {}
        for sample in samplers:
            samples.update(sample(ownership, new))
        new_needs = DomainNeeds(
            rows=jnp.maximum(needs.rows, held),
            halo=jnp.maximum(needs.halo, sent),
            migrants=jnp.maximum(needs.migrants, migrants),
        )
        per_device = {"rows": kept, "pair_list": new.pair_list, "needs": new_needs}
        result = state.set(
            **{name: jax.tree.map(lambda leaf: leaf[None], v) for name, v in per_device.items()},
            virial={part: ownership.across_devices(share) for part, share in new.virial.items()},
            step=new.step,
            time=new.time,
            flags=state.flags | bits.astype(jnp.int32),
            box_state=new.box_state,
        )
        return result, samples

    searches = {}

    def search_for(rows_stepped: int):
        """The cell list over a device's view for `rows_stepped` rows (built once
        per buffer size); the list is rebuilt every step, as the rows change."""
        if rows_stepped not in searches:
            # Its tables are constants of every step that uses it, not of the first
            # trace that asked for it.
            with jax.ensure_compile_time_eval():
                searches[rows_stepped] = cell_list_search(
                    view, rows_stepped, reach, 0.0, absent_rows=True, density=density
                )
        return searches[rows_stepped]

    def step_fn(state):
        search = search_for(state.rows.ids.shape[1] + 2 * state.halo_capacity)
        specs = _sharded_fields(state)
        mapped = jax.shard_map(
            lambda local: step_on_device(local, search),
            mesh=mesh,
            in_specs=(specs,),
            out_specs=(specs, P()),
            check_vma=False,
        )
        return mapped(state)

    def deal(
        arrays, box_state, template, capacity, halo_capacity, migration_capacity, pairs, cells
    ):
        """A DecomposedState holding the particles of `arrays` (NumPy, scene order)."""
        bound = box.bind(box_state)
        s = np.asarray(_frame_coordinate(bound, jnp.asarray(arrays["positions"]), axis))
        owner = np.clip(np.floor(s / width).astype(np.int64), 0, devices - 1)
        counts = np.bincount(owner, minlength=devices)
        if counts.max() > capacity:
            capacity = math.ceil(counts.max() * multiplier)
        free = exchange.free_rows(capacity, dtype)
        rows = {
            field.name: np.stack([np.asarray(getattr(free, field.name))] * devices)
            for field in dataclasses.fields(free)
        }
        for device in range(devices):
            members = np.flatnonzero(owner == device)
            rows["ids"][device, : members.size] = members
            for name in PARTICLE_FIELDS:
                rows[name][device, : members.size] = arrays[name][members]
        stepped = capacity + 2 * halo_capacity
        origins = np.arange(devices) * width - halo
        pair_list = PairList(
            i=np.full((devices, pairs), stepped, np.int32),
            j=np.full((devices, pairs), stepped, np.int32),
            reference_positions=np.zeros((devices, stepped, 3), dtype),
            reference_box_state=SlabState(
                jax.tree.map(lambda leaf: np.stack([np.asarray(leaf)] * devices), box_state),
                origins.astype(dtype),
            ),
            needed_pairs=np.zeros(devices, np.int32),
            needed_cell_occupancy=np.zeros(devices, np.int32),
            overflow=np.zeros(devices, bool),
            rebuilds=np.zeros(devices, np.int32),
            cell_capacity=cells,
        )
        zeros = np.zeros(devices, np.int32)
        state = template.set(
            rows=Rows(**rows),
            pair_list=pair_list,
            needs=DomainNeeds(zeros, zeros, zeros),
            halo_capacity=halo_capacity,
            migration_capacity=migration_capacity,
        )
        specs = _sharded_fields(state)
        return jax.tree.map(
            lambda leaf, spec: jax.device_put(jnp.asarray(leaf), NamedSharding(mesh, spec)),
            state,
            specs,
        )

    def pair_room() -> int:
        """Pair buffer of a device: the ideal-gas pair count of its slab and halos."""
        density = scene.n_particles / box.volume
        present = scene.n_particles * (width + 2 * halo) / layout.box_length
        ideal = 0.5 * present * density * 4 / 3 * math.pi * reach**3
        return max(16, math.ceil(ideal * multiplier))

    def init_fn(positions=None, velocities=None):
        state = serial.init_fn(positions, velocities)
        template = DecomposedState(
            rows=None,
            pair_list=None,
            needs=None,
            virial=state.virial,
            step=state.step,
            time=state.time,
            seed=state.seed,
            flags=state.flags,
            box_state=state.box_state,
            parameters=state.parameters,
        )
        arrays = {name: np.asarray(getattr(state, name)) for name in PARTICLE_FIELDS}
        cells = state.pair_list.cell_capacity if serial.neighbor_search is not None else 1
        return deal(
            arrays,
            state.box_state,
            template,
            layout.capacity,
            layout.halo_capacity,
            layout.migration_capacity,
            pair_room(),
            cells,
        )

    def buffer_needs(state) -> tuple:
        pair_list, needs = state.pair_list, state.needs
        return tuple(
            int(np.max(np.asarray(value)))
            for value in (
                pair_list.needed_pairs,
                pair_list.needed_cell_occupancy,
                needs.rows,
                needs.halo,
                needs.migrants,
            )
        )

    def buffer_shapes(state) -> tuple:
        return (
            state.pair_list.i.shape[1],
            state.pair_list.cell_capacity,
            state.rows.ids.shape[1],
            state.halo_capacity,
            state.migration_capacity,
        )

    def sizes_for(needs) -> list:
        """Buffer sizes holding `needs`: the pairs with the capacity multiplier's head
        room, the cell slots with a fifth (at least 3) to spare, the rows with
        `head_room` (free rows are stepped like the others, so they cost time)."""
        pairs = max(16, math.ceil(needs[0] * multiplier))
        cells = needs[1] + max(3, math.ceil(0.2 * needs[1]))
        capacity, halo, migration = (math.ceil(head_room(n)) for n in needs[2:])
        return [pairs, cells, capacity, halo, migration]

    def fitted_shapes(state) -> tuple:
        """The sizes `reallocate(state, None)` gives (the current ones before any step)."""
        needs = buffer_needs(state)
        return buffer_shapes(state) if needs[2] == 0 else tuple(sizes_for(needs))

    def reallocate(state, needs):
        """Buffers re-sized with the head room of `sizes_for`: for `needs`
        (`buffer_needs` of an overflowed chunk), never smaller than before; or, with
        None, fitted to what the state's own steps needed (`DecomposedState.needs`
        and the last pair list), smaller or larger: a state that has left its random
        start needs far fewer cell slots than the start did."""
        shapes = buffer_shapes(state)
        fitting = needs is None
        needs = buffer_needs(state) if fitting else needs
        if fitting and needs[2] == 0:  # not stepped since its buffers were sized
            return state
        sizes = sizes_for(needs)
        if not fitting:
            sizes = [max(size, shape) for size, shape in zip(sizes, shapes, strict=True)]
        pairs, cells, capacity, halo_capacity, migration_capacity = sizes
        template = state.set(flags=jnp.asarray(0, jnp.int32))
        return deal(
            state.particles(),
            jax.tree.map(np.asarray, state.box_state),
            template,
            capacity,
            halo_capacity,
            migration_capacity,
            pairs,
            cells,
        )

    return DecomposedSimulation(
        scene=scene,
        box=box,
        blocks=serial.blocks,
        dtype=dtype,
        masses=None,
        neighbor_search=None,
        spring_search=None,
        init_fn=init_fn,
        step_fn=step_fn,
        reallocate=reallocate,
        init_observers=lambda state: state,
        buffer_needs=buffer_needs,
        buffer_shapes=buffer_shapes,
        fitted_shapes=fitted_shapes,
        layout=layout,
        mesh=mesh,
    )
