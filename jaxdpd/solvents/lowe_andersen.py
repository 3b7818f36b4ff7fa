"""Lowe–Andersen thermostat: pairwise Maxwellian thermalisation, exact and parallel.

Lowe, Europhys. Lett. 47, 145 (1999); thesis §2.3.2, eqs. 2.19–2.22 and table 2.1.
Every pair closer than the thermalisation cut-off r_T is selected with probability
ΓΔt (Γ the bath collision frequency).  A selected pair gets a new relative velocity
along e_ij = r_ij/|r_ij|, drawn from the Maxwell distribution of a pair,

    u'_ij = ξ_ij √(k_BT/μ_ij),   μ_ij = m_i m_j/(m_i + m_j),   ξ_ij ~ N(0, 1)

(for unit masses √(2k_BT), eq. 2.19), by equal and opposite momentum changes

    m_i Δv_i = −m_j Δv_j = μ_ij (u'_ij − u_ij) e_ij,   u_ij = (v_i − v_j)·e_ij

(eq. 2.21 with masses), so total momentum is conserved exactly.

Sequential semantics, computed in parallel
------------------------------------------
Lowe's algorithm visits the selected pairs one after another: each pair sees the
velocities left by the pairs before it.  (Summing all pair updates computed from the
velocities before the sweep is a different algorithm, which overshoots once a
particle has several selected partners and overheats or diverges at large ΓΔt.)  Here
the visiting order is random and counter-based: pair (i, j) has the order key

    k_ij = (priority_ij, i XOR j),

with priority_ij the top bits of a hash of (seed, step, min(i,j), max(i,j)).  Pairs
sharing particle i have distinct partners, hence distinct i XOR j, so k is a strict
total order among the pairs of any one particle.  The sweep runs in rounds: in a
round every selected pair whose key is the smallest among the pending pairs of BOTH
its particles is applied.  These pairs share no particle, so they are applied at
once.  When a pair is applied, all the lower-keyed pairs it conflicts with were
applied in earlier rounds and all the higher-keyed ones are still pending, so every
particle sees its pairs in key order; updates of disjoint pairs commute, hence the
result equals the sequential sweep in key order exactly (ties in k between disjoint
pairs are immaterial).  The pending pair of smallest key is always applicable, so
the loop ends; the number of rounds is the longest key-increasing chain of
conflicting pairs (tens at ΓΔt = 1; see benchmarks/lowe_andersen_cost.py).

A round costs O(N), not O(number of pairs): the selected pairs are listed twice,
once per particle (half-edges), sorted by (particle, k) into one uint64 key per
half-edge; each particle then holds a pointer to its first pending half-edge.  A
pair is ready when it is at the head of both its particles' lists, which each
particle checks on its own (the partner is particle XOR (i XOR j)).  Both particles
of a ready pair compute the same update from the same operands, each applies its
own half: no scatter, and momentum is conserved to round-off.

All random numbers are counter-based (jaxdpd.engine.noise): the selection uniform, the
priority and the Gaussian ξ are separate streams of the pair hash, so a trajectory
does not depend on the neighbour-list format, capacity or order.

Rows and identities: the sweep runs over rows, which on one device are the
particles.  In a decomposed run (jaxdpd.decomposition) a device's rows are its own
particles, copies of its neighbours' near its faces and free rows; the step's
`Ownership` (jaxdpd.engine.ownership) gives each row's identity, which keys the
selection, the order and ξ (i XOR j above is of identities), and resends the copies'
velocities and first pending pairs from their owners before every round, so each
device applies exactly the pairs of the global round to its own particles
(docs/scaling_out.md, "Lowe–Andersen").
"""

from dataclasses import dataclass
from typing import ClassVar, NamedTuple

import jax
import jax.numpy as jnp

from jaxdpd import pytree
from jaxdpd.engine import noise
from jaxdpd.engine.integrators import thermalized_velocity_verlet
from jaxdpd.engine.ownership import WHOLE_SYSTEM
from jaxdpd.forces.pair_sums import pair_geometry
from jaxdpd.scatter import segment_sum_where
from jaxdpd.scene_examples import chain_solution_example
from jaxdpd.solvents import component
from jaxdpd.solvents.groot_warren import velocity_verlet
from jaxdpd.validation import read_number

# Streams of jaxdpd.engine.noise.pair_bits; the Gaussian ξ uses streams 0 and 1
# (jaxdpd.engine.noise.pair_gaussian).
SELECTION_STREAM = 2
PRIORITY_STREAM = 3

# Components (a, b) of the symmetric impulse virial accumulated per particle.
_VIRIAL_COMPONENTS = ((0, 0), (1, 1), (2, 2), (0, 1), (0, 2), (1, 2))


@pytree.dataclass
class LoweAndersenRecord:
    """What the thermalisation of one step did (kept in SimState.solvent_state).

    Attributes:
        impulse_virial: (3, 3) Σ_pairs r_ij ⊗ μ_ij Δv_ij / Δt, the thermostat's part
            of the virial (thesis eq. 3.47, third term; zeros unless the scene asks
            for the pressure).
        thermalized_pairs: int32, number of pairs selected this step.
        rounds: int32, number of parallel rounds the sweep took.
    """

    impulse_virial: jnp.ndarray
    thermalized_pairs: jnp.ndarray
    rounds: jnp.ndarray


def empty_record(dtype) -> LoweAndersenRecord:
    """The record before the first step (no pair thermalised yet)."""
    zero = jnp.asarray(0, jnp.int32)
    return LoweAndersenRecord(jnp.zeros((3, 3), dtype), zero, zero)


def order_key_bits(n_particles: int) -> tuple[int, int]:
    """Bit layout of the uint64 half-edge sort key (owner | priority | i XOR j).

    Args:
        n_particles: N (the owner field also holds N, the "not selected" mark).
    Returns:
        (index_bits, priority_bits): index_bits = bit length of N, enough for a
        particle index, for N and for i XOR j; priority_bits = min(32, 64 − 2
        index_bits), i.e. the full 32-bit hash up to N = 65535 and fewer bits
        beyond (ties are then broken by i XOR j, which keeps the order exact and
        independent of the neighbour list).
    """
    index_bits = int(n_particles).bit_length()
    priority_bits = min(32, 64 - 2 * index_bits)
    if priority_bits < 1:
        raise ValueError(f"n_particles = {n_particles}: too many particles for a 64-bit key")
    return index_bits, priority_bits


def pair_order_keys(key, i, j, n_particles: int):
    """Order keys k_ij = (priority_ij << index_bits) | (i XOR j) of the sweep.

    Args:
        key: uint32 step key (jaxdpd.engine.noise.step_key).
        i, j: (P,) int particle indices.
        n_particles: N (sets the bit layout, see `order_key_bits`).
    Returns:
        (P,) uint64, symmetric in (i, j); pairs are visited in increasing k.
    """
    index_bits, priority_bits = order_key_bits(n_particles)
    priority = noise.pair_bits(key, i, j, PRIORITY_STREAM) >> (32 - priority_bits)
    tie_break = (i ^ j).astype(jnp.uint64)
    return (priority.astype(jnp.uint64) << index_bits) | tie_break


def selected(key, i, j, probability, dtype):
    """True for the pairs thermalised this step: uniform variate < ΓΔt.

    Args:
        key: uint32 step key; i, j: (P,) particle indices.
        probability: ΓΔt in [0, 1] (1 selects every pair).
        dtype: floating dtype of the comparison.
    """
    uniform = noise.bits_to_unit_interval(noise.pair_bits(key, i, j, SELECTION_STREAM), dtype)
    return uniform < jnp.asarray(probability, dtype)


def target_relative_velocity(key, i, j, kT, reduced_mass, dtype):
    """New relative normal velocity u'_ij = ξ_ij √(k_BT/μ_ij) (thesis eq. 2.19).

    Args:
        key: uint32 step key; i, j: particle indices (any shape).
        kT: k_BT (energy).
        reduced_mass: μ_ij = m_i m_j/(m_i + m_j), scalar or shaped like i.
        dtype: floating dtype.
    Returns:
        Gaussian variates of variance k_BT/μ_ij, symmetric in (i, j).
    """
    return noise.pair_gaussian(key, i, j, dtype) * jnp.sqrt(kT / reduced_mass)


def relative_normal_velocity(velocity_i, velocity_j, unit, streaming=None):
    """u_ij = (v_i − v_j)·e_ij in the laboratory frame, from stored velocities.

    The one place where the thermostat forms a pair's relative velocity.  In a
    flowing box the stored velocities are peculiar (c = v − u(r)) and the flow's
    part (L r_ij)·e_ij is added, r_ij the minimum image across the moving boundary:
    the relative velocity across a Lees–Edwards boundary carries the jump γ̇ L_y x̂
    (thesis eq. 3.18).  The thermostat must act on laboratory velocities, or it
    exerts no shear stress (thesis §3.4).

    Args:
        velocity_i, velocity_j: (c_x, c_y, c_z) of the two particles, each (K,).
        unit: (e_x, e_y, e_z), each (K,).
        streaming: (K,) (L r_ij)·e_ij (PairGeometry.streaming), or None at rest.
    Returns:
        (K,) u_ij.
    """
    normal = sum((a - b) * e for a, b, e in zip(velocity_i, velocity_j, unit, strict=True))
    return normal if streaming is None else normal + streaming


class _HalfEdges(NamedTuple):
    """Selected pairs listed once per particle, sorted by (row, order key).

    Attributes:
        i, j: (H,) owner and partner row of each half-edge; i ≥ R (the row
            count) past the selected ones.
        tie_break: (H,) int32 identity XOR of the pair (i XOR j on one device).
        start, stop: (R,) each row's half-edges are [start, stop).
    """

    i: jnp.ndarray
    j: jnp.ndarray
    tie_break: jnp.ndarray
    start: jnp.ndarray
    stop: jnp.ndarray


def _half_edges(
    pair_i, pair_j, chosen, order_keys, n_particles: int, rows: int, ownership
) -> _HalfEdges:
    """Sort the selected pairs' two half-edges by (owner row, order key).

    Args:
        pair_i, pair_j: (P,) rows of the listed pairs.
        chosen: (P,) bool, selected (each pair at most once).
        order_keys: (P,) uint64 from `pair_order_keys` (of the pairs' identities).
        n_particles: N.
        rows: R, the rows of the arrays swept (N on one device).
        ownership: the rows' `Ownership` (jaxdpd.engine.ownership): identities and
            the row of an identity.
    """
    index_bits, priority_bits = order_key_bits(n_particles)
    index_mask = jnp.uint64((1 << index_bits) - 1)
    owner_bits = rows.bit_length()
    owners = jnp.concatenate([pair_i, pair_j])
    selected_twice = jnp.concatenate([chosen, chosen])
    # Unselected half-edges all get the largest key: they sort last, as an owner
    # ≥ R, and many equal keys sort faster than distinct ones.
    unselected = jnp.uint64(2**64 - 1)
    if owner_bits + priority_bits + index_bits <= 64:
        # One single-key sort: the owner row in the top bits, the order key below.
        shift = 64 - owner_bits
        keys = (owners.astype(jnp.uint64) << shift) | jnp.concatenate([order_keys, order_keys])
        sorted_keys = jnp.sort(jnp.where(selected_twice, keys, unselected))
        owner = (sorted_keys >> shift).astype(jnp.int32)
    else:
        # More rows than the key has room for (a device's buffers beyond 2^bits):
        # the same order from a sort on two keys.
        owner, sorted_keys = jax.lax.sort(
            (
                jnp.where(selected_twice, owners, rows),
                jnp.where(selected_twice, jnp.concatenate([order_keys, order_keys]), unselected),
            ),
            num_keys=2,
        )
    tie_break = (sorted_keys & index_mask).astype(jnp.int32)
    partner_identity = ownership.identity_of(jnp.minimum(owner, rows - 1)) ^ tie_break
    ones = chosen.astype(jnp.int32)
    counts = segment_sum_where(ones, pair_i, chosen, rows) + segment_sum_where(
        ones, pair_j, chosen, rows
    )
    stop = jnp.cumsum(counts, dtype=jnp.int32)
    return _HalfEdges(owner, ownership.row_of(partner_identity), tie_break, stop - counts, stop)


class _EdgeData(NamedTuple):
    """What a half-edge's pair needs in the sweep, gathered per round by head index.

    Attributes:
        unit: (e_x, e_y, e_z), each (H,), e_ij from the partner j to the owner i.
        distance: (H,) r_ij.
        streaming: (H,) (L r_ij)·e_ij in a flowing box, else None.
        target: (H,) new relative normal velocity u'_ij.
        reduced_mass: μ_ij, (H,) or the scalar ½ (unit masses).
        share: μ_ij/m_i, the owner's part of the velocity change, (H,) or ½.
    """

    unit: tuple
    distance: jnp.ndarray
    streaming: jnp.ndarray | None
    target: jnp.ndarray
    reduced_mass: object
    share: object


def _edge_data(
    bound_box, positions, edges: _HalfEdges, key, kT, masses, dtype, identities
) -> _EdgeData:
    """Geometry, masses and Maxwellian targets of every half-edge (owner ≥ R: inert);
    `identities` as in `pair_geometry` (the targets are keyed by them)."""
    geometry = pair_geometry(bound_box, positions, edges, jnp.inf, True, identities)
    unit = tuple(s * geometry.inverse_distance for s in geometry.separation)
    if masses is None:
        reduced_mass, share = 0.5, 0.5
    else:
        mass_i, mass_j = masses[geometry.i], masses[geometry.j]
        reduced_mass = mass_i * mass_j / (mass_i + mass_j)
        share = mass_j / (mass_i + mass_j)
    target = target_relative_velocity(key, *geometry.identity_pairs(), kT, reduced_mass, dtype)
    return _EdgeData(unit, geometry.distance, geometry.streaming, target, reduced_mass, share)


def _per_edge(value, h):
    """value[h] for per-half-edge arrays; scalars (unit masses) pass through."""
    return value[h] if jnp.ndim(value) else value


def _sweep(edges: _HalfEdges, data: _EdgeData, velocities, with_virial: bool, ownership):
    """The rounds of the sequential-equivalent sweep (see the module docstring).

    Args:
        edges: the sorted half-edges.
        data: their pair data.
        velocities: (R, 3) before the sweep.
        with_virial: also accumulate Σ r_ij ⊗ μ Δu e_ij.
        ownership: the rows' `Ownership`: before each round the halo copies take
            their owners' velocities and first pending pairs (`resend`), and the
            rounds go on while any owned row, on any device, has a pending pair.
    Returns:
        ((R, 3) velocities after the sweep (the owned rows'), the (3, 3)
        Σ r_ij ⊗ μ_ij Δu_ij e_ij of the owned rows' halves, int32 number of rounds).
    """
    n, dtype = velocities.shape[0], velocities.dtype
    last = edges.i.shape[0] - 1

    def going_on(head, ready):
        """Whether an owned row on any device has a pending pair, and the last round
        applied a pair somewhere.  It always does while pairs are pending (the
        pending pair of smallest key is ready), unless a partner is missing from a
        device, which the decomposition flags (StepError.DOMAIN_REACH): then the
        sweep stops instead of waiting for it."""
        return jnp.all(ownership.system_any(jnp.stack([head < edges.stop, ready], axis=1)))

    def round_(carry):
        head, v, virial_parts, rounds, _ = carry
        h = jnp.minimum(head, last)
        # i XOR j (identities) of each particle's first pending pair (0: none
        # pending); a copy takes its owner's, with its velocity.
        head_pair = jnp.where(head < edges.stop, edges.tie_break[h], 0)
        v, head_pair = ownership.resend((v, head_pair))
        partner = edges.j[h]
        ready = (head_pair != 0) & (head_pair[partner] == head_pair)
        e = [component[h] for component in data.unit]
        streaming = None if data.streaming is None else data.streaming[h]
        normal = relative_normal_velocity(v, [c[partner] for c in v], e, streaming)
        change = jnp.where(ready, data.target[h] - normal, 0)
        speed = change * _per_edge(data.share, h)
        v = tuple(c + speed * unit_c for c, unit_c in zip(v, e, strict=True))
        if with_virial:
            # r_ij ⊗ μ Δu e_ij = μ Δu r e_a e_b, half at each of the two particles.
            weight = change * 0.5 * data.distance[h] * _per_edge(data.reduced_mass, h)
            virial_parts = tuple(
                part + weight * e[a] * e[b]
                for part, (a, b) in zip(virial_parts, _VIRIAL_COMPONENTS, strict=True)
            )
        head = head + ready
        return head, v, virial_parts, rounds + 1, going_on(head, ready)

    parts = tuple(jnp.zeros(n, dtype) for _ in _VIRIAL_COMPONENTS) if with_virial else ()
    # Velocity components as separate arrays (structure of arrays) in the loop.
    carry = (edges.start, tuple(velocities.T), parts, jnp.asarray(0, jnp.int32))
    carry = carry + (going_on(edges.start, jnp.ones_like(edges.start, bool)),)
    _, components, parts, rounds, _ = jax.lax.while_loop(lambda c: c[-1], round_, carry)
    virial = jnp.zeros((3, 3), dtype)
    for part, (a, b) in zip(parts, _VIRIAL_COMPONENTS[: len(parts)], strict=True):
        total = ownership.share(part)
        virial = virial.at[a, b].set(total).at[b, a].set(total)
    return jnp.stack(components, axis=1), virial, rounds


def lowe_andersen_thermostat(
    n_particles: int,
    collision_probability: float,
    kT: float,
    cutoff: float,
    dt: float,
    dtype,
    half: bool,
    masses=None,
    with_virial: bool = False,
    ownership=None,
):
    """The Lowe–Andersen thermalisation of one step (see the module docstring).

    Args:
        n_particles: N.
        collision_probability: ΓΔt in [0, 1], the chance that a pair within the
            cut-off is thermalised in a step.
        kT: k_BT of the bath.
        cutoff: thermalisation cut-off r_T (pairs with r_ij < r_T take part).
        dt: time step Δt (the impulse virial is a mean force over Δt, eq. 2.22).
        dtype: floating dtype of positions and velocities.
        half: whether the neighbour lists hold each pair once (else twice).
        masses: (N,) particle masses, or None for unit masses (μ_ij = ½).
        with_virial: record the impulse virial (else zeros, nothing traced).
        ownership: in a decomposed run, the device's rows (jaxdpd.engine.ownership);
            None: one device holding the N particles in identity order.
    Returns:
        `thermalize(bound_box, positions, velocities, pair_list, key) ->
        (velocities, record)` with the box bound to its current state
        (`box.bind(box_state)`), positions and (peculiar) velocities (R, 3), a
        PairList covering r_T, the uint32 step key (jaxdpd.engine.noise.step_key) and a
        `LoweAndersenRecord` (its impulse virial the owned rows' share, as every
        virial part of a decomposed step).
    """
    n = n_particles
    ownership = ownership or WHOLE_SYSTEM
    kT_ = jnp.asarray(kT, dtype)
    inverse_dt = jnp.asarray(1.0 / dt, dtype)

    def thermalize(bound_box, positions, velocities, pair_list, key):
        identities = ownership.identities
        pairs = pair_geometry(bound_box, positions, pair_list, cutoff, half, identities)
        first, second = pairs.identity_pairs()
        chosen = pairs.within & selected(key, first, second, collision_probability, dtype)
        if not half:  # a full list holds (i, j) and (j, i): keep one
            chosen = chosen & (pairs.i < pairs.j)
        order_keys = pair_order_keys(key, first, second, n)
        rows = positions.shape[0]
        edges = _half_edges(pairs.i, pairs.j, chosen, order_keys, n, rows, ownership)
        data = _edge_data(bound_box, positions, edges, key, kT_, masses, dtype, identities)
        velocities, impulse_moment, rounds = _sweep(edges, data, velocities, with_virial, ownership)
        # Each selected pair has two half-edges, one at each of its particles.
        pair_count = ownership.system_sum(edges.stop - edges.start) // 2
        return velocities, LoweAndersenRecord(impulse_moment * inverse_dt, pair_count, rounds)

    return thermalize


@dataclass(frozen=True)
class LoweAndersenParameters(component.SolventParameters):
    """solvent.method = "lowe_andersen": k_BT, the bath collision frequency Γ and the
    thermalisation cut-off r_T (None for the scene's cutoff)."""

    method: ClassVar[str] = "lowe_andersen"
    collision_frequency: float = 0.0
    thermalization_cutoff: float | None = None


class LoweAndersen(component.SolventMethod):
    """The Lowe–Andersen thermostat (module docstring) in velocity Verlet: kT > 0,
    collision_frequency Γ ≥ 0 (0 = thermostat off; Γ · integrator.dt ≤ 1),
    thermalization_cutoff r_T > 0 (default: cutoff).  No integrator.lambda: the step
    has no velocity-dependent force to predict."""

    name = "lowe_andersen"
    fields = ("collision_frequency", "thermalization_cutoff")
    flows = ("shear", "planar_elongation")
    integrator_lambda = False
    uses_neighbor_list = True
    decomposition = "forces_after_drift"
    heating_advice = (
        "lower the flow rate (the heating at rates near 1 and above hardly depends on "
        "Δt) or reduce integrator.dt; collision_frequency · dt must stay ≤ 1"
    )

    def read(self, section) -> LoweAndersenParameters:
        """The Lowe–Andersen thermostat's parameters (thesis §2.3.2)."""
        misplaced = sorted({"gamma", "sigma", "noise", "pi0", "omega", "delta_pi"} & set(section))
        if misplaced:
            raise ValueError(
                f"solvent: {misplaced} are not parameters of method 'lowe_andersen' (it has "
                f"kT and {list(self.fields)}; the pair collisions replace the "
                "dissipative and random forces)"
            )
        if "collision_frequency" not in section:
            raise ValueError(
                "solvent.collision_frequency: required field is missing (the bath collision "
                "frequency Γ of method 'lowe_andersen', ≥ 0, with Γ · integrator.dt ≤ 1)"
            )
        return LoweAndersenParameters(
            kT=read_number(section, "kT", "solvent", 1.0, minimum=0, exclusive_minimum=True),
            collision_frequency=read_number(section, "collision_frequency", "solvent", minimum=0),
            thermalization_cutoff=read_number(
                section, "thermalization_cutoff", "solvent", None, minimum=0, exclusive_minimum=True
            ),
        )

    def to_dict(self, parameters) -> dict:
        data = {
            "method": "lowe_andersen",
            "kT": parameters.kT,
            "collision_frequency": parameters.collision_frequency,
        }
        if parameters.thermalization_cutoff is not None:
            data["thermalization_cutoff"] = parameters.thermalization_cutoff
        return data

    def check_integrator(self, parameters, section, integrator) -> None:
        if "lambda" in section:
            raise ValueError(
                "integrator.lambda: the Lowe–Andersen step has no velocity-dependent force, "
                "so the λ of Groot and Warren's modified velocity Verlet plays no role; "
                "remove it"
            )

    def pair_range(self, parameters, cutoff: float) -> tuple[str, float]:
        """r_c, or a longer r_T."""
        reach = parameters.thermalization_cutoff
        if reach is not None and reach > cutoff:
            return "solvent.thermalization_cutoff", reach
        return "cutoff", cutoff

    def check(self, scene) -> None:
        """Γ Δt is the probability that a pair is thermalised in a step: at most 1."""
        frequency, dt = scene.solvent.collision_frequency, scene.integrator.dt
        if frequency * dt > 1 + 1e-12:
            raise ValueError(
                f"solvent.collision_frequency × integrator.dt = {frequency:g} × {dt:g} = "
                f"{frequency * dt:.4g} > 1: Γ Δt is the probability that a pair is "
                f"thermalised in a step (thesis §2.3.2); use collision_frequency ≤ 1/dt = "
                f"{1 / dt:.6g} or integrator.dt ≤ 1/collision_frequency = {1 / frequency:.6g}"
            )

    def bath_cutoff(self, scene) -> float | None:
        """r_T of an active thermostat (default r_c), else None."""
        solvent = scene.solvent
        if solvent.collision_frequency == 0:
            return None
        if solvent.thermalization_cutoff is None:
            return scene.cutoff
        return solvent.thermalization_cutoff

    def example_scene(self, precision="float64") -> dict:
        """300 particles at ρ = 3 with 15 Hookean 4-bead chains, soft repulsion a = 25,
        collision frequency Γ = 2."""
        return chain_solution_example(
            precision,
            {"method": "lowe_andersen", "kT": 1.0, "collision_frequency": 2.0},
            4.0,
            pair={"a": 25.0},
            integrator={"dt": 0.04},
        )

    def advance(self, context):
        scene = context.scene
        bath_cutoff = self.bath_cutoff(scene)
        if bath_cutoff is None:
            return velocity_verlet(context)
        box, dt = context.box, scene.integrator.dt
        lowe_andersen = lowe_andersen_thermostat(
            scene.n_particles,
            min(1.0, scene.solvent.collision_frequency * dt),
            scene.solvent.kT,
            bath_cutoff,
            dt,
            context.dtype,
            context.search.half,
            context.masses,
            context.with_virial,
            context.ownership,
        )

        def thermalize(state, velocities):
            """Thermalise at the state's positions and box; noise keyed by its step."""
            key = noise.step_key(state.seed, state.step)
            bound_box = box.bind(state.box_state)
            return lowe_andersen(bound_box, state.positions, velocities, state.pair_list, key)

        return thermalized_velocity_verlet(
            box,
            dt,
            context.interactions,
            thermalize,
            scene.solvent.kT,
            context.dtype,
            context.masses,
            context.with_virial,
            context.ownership,
        )

    def initial_solvent_state(self, scene, dtype):
        if self.bath_cutoff(scene) is None:
            return None
        return empty_record(dtype)
