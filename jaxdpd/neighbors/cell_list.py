"""jaxdpd's cell-list half neighbour list.

Particles are binned, by their coordinates in the box's frame (the positions
themselves in a box at rest, sheared coordinates in a Lees–Edwards box; see
jaxdpd.boxes), into cells at least r_c + skin thick and laid out on a padded grid
(slot, c_x, c_y, c_z) of per-cell member slots.  Each cell is compared with itself
(slot pairs j > i) and with 13 "forward" neighbour cells (a half stencil), so every
pair is found exactly once.  The neighbour blocks are whole-grid rolls, and the
distance tests are dense element-wise arithmetic on (slot, cell) planes: XLA's CPU
backend runs these far faster than per-particle gathers of candidates.  Each test
result is packed into 32-bit words, one bit per candidate slot, and the accepted pairs
are compacted into flat (i, j) arrays with prefix sums over popcounts, one scatter
and a cumulative maximum (O(N + capacity), no per-pair search over the rows).

Axes with fewer than three cells fall back to a single cell along that axis (every
particle is a candidate along it, measured by the minimum image in the frame, which
stays unique because the scene requires every cell height > 2 (r_c + skin)).
"""

import itertools
import math

import jax
import jax.numpy as jnp
import numpy as np

from jaxdpd.neighbors.pair_list import NeighborSearch, PairList, needs_rebuild

WORD_BITS = 32


def cell_grid(box, list_cutoff: float) -> tuple[int, int, int]:
    """Cells per frame axis: ⌊h/r_list⌋ with h the box's thinnest extent along that
    axis (`box.cell_heights`: the edge of a box at rest), or 1 where that would be
    fewer than 3."""
    counts = []
    for height in box.cell_heights:
        n = int(math.floor(height / list_cutoff))
        counts.append(n if n >= 3 else 1)
    return tuple(counts)


def stencil(n_cells: tuple[int, int, int]) -> list[tuple[int, int, int]]:
    """The own cell (0, 0, 0) followed by the lexicographically positive offsets of
    {−1, 0, 1}³ (only 0 along single-cell axes): every unordered pair of distinct
    cells is visited from exactly one side."""
    choices = [(-1, 0, 1) if n >= 3 else (0,) for n in n_cells]
    return [(0, 0, 0)] + [o for o in itertools.product(*choices) if o > (0, 0, 0)]


def _lower_bound(values_at, length: int, targets):
    """Smallest index k in [0, length] with values_at(k) ≥ target (monotone values).

    Branch-free binary search with a fixed number of halvings, vectorised over
    `targets`; `values_at(k)` gathers the values at index array k.
    """

    def halve(_, bounds):
        lo, hi = bounds
        mid = (lo + hi) // 2
        below = (values_at(jnp.minimum(mid, length - 1)) < targets) & (mid < length)
        return jnp.where(below, mid + 1, lo), jnp.where(below, hi, mid)

    bounds = (jnp.zeros_like(targets), jnp.full_like(targets, length))
    iterations = max(1, math.ceil(math.log2(length + 1)))
    return jax.lax.fori_loop(0, iterations, halve, bounds)[0]


def _cell_coordinates(positions, cell_size, n_cells):
    """Integer cell coordinates (c_x, c_y, c_z) of each particle, (N, 3) int32."""
    cell_xyz = jnp.floor(positions / jnp.asarray(cell_size, positions.dtype)).astype(jnp.int32)
    return jnp.clip(cell_xyz, 0, jnp.asarray(n_cells, jnp.int32) - 1)


def _cell_id(cell_xyz, n_cells):
    """Cell id (c_x n_y + c_y) n_z + c_z from integer coordinates (..., 3)."""
    return (cell_xyz[..., 0] * n_cells[1] + cell_xyz[..., 1]) * n_cells[2] + cell_xyz[..., 2]


def _bin(cell_ids, n_cells_total: int, cell_capacity: int):
    """Sort particles into per-cell slots.

    Returns:
        members: (cell_capacity, n_cells_total) int32, the particle in each slot
            (N when empty).
        slot: (N,) int32, each particle's slot within its cell.
        max_occupancy: int32 scalar.
    """
    n = cell_ids.shape[0]
    # Sorting one packed int64 key (cell, index) is several times faster on CPU
    # than argsort's key–index pair sort; the result is the same stable order.
    packed = cell_ids.astype(jnp.int64) * n + jnp.arange(n, dtype=jnp.int64)
    order = (jnp.sort(packed) % n).astype(jnp.int32)
    counts = jnp.zeros(n_cells_total, jnp.int32).at[cell_ids].add(1)
    starts = jnp.cumsum(counts) - counts
    rank = jnp.arange(n, dtype=jnp.int32) - starts[cell_ids[order]]
    slot = jnp.zeros(n, jnp.int32).at[order].set(rank)
    slots = jnp.arange(cell_capacity, dtype=jnp.int32)[:, None]
    gathered = order[jnp.clip(starts[None, :] + slots, 0, n - 1)]
    return jnp.where(slots < counts[None, :], gathered, n), slot, jnp.max(counts)


# Size (offsets × slots × cells) up to which all stencil offsets are tested at once.
_SMALL_GRID_ELEMENTS = 1 << 18


def _accepted_words(bound_box, frame, members, n_cells, offsets, list_cutoff):
    """Distance tests of every (slot, cell) against the slots of its stencil cells.

    Args:
        bound_box: the box at this instant (frame lengths, frame → Cartesian).
        frame: (N, 3) frame coordinates of the particles.
        members: (slots, cells) particle in each slot (N when empty).
        offsets: the stencil, own cell first.
    Returns:
        (words, slots, cells) uint32; bit b of word (o, g) says whether slot
        g·32 + b of the neighbour cell (cell + offset o) is within r_list.
    """
    n = frame.shape[0]
    dtype = frame.dtype
    lengths = bound_box.lengths
    cell_capacity = members.shape[0]
    grid_shape = (cell_capacity,) + n_cells
    members = members.reshape(grid_shape)
    empty = members >= n
    safe = jnp.minimum(members, n - 1)
    # Empty slots hold NaN: every comparison with them is False.
    coordinates = [
        jnp.where(empty, jnp.asarray(jnp.nan, dtype), frame[:, axis][safe]) for axis in range(3)
    ]
    limit = jnp.asarray(list_cutoff**2, dtype)
    groups = math.ceil(cell_capacity / WORD_BITS)
    slot_index = np.arange(cell_capacity)
    # Small grids test all offsets in one batch (a few large fused loops instead of
    # many tiny ones: dispatch, not arithmetic, bounds small systems); large grids
    # test one offset at a time (measured: intermediate batches run slower than both).
    small = len(offsets) * members.size <= _SMALL_GRID_ELEMENTS
    batch_size = len(offsets) if small else 1
    words = []
    for first in range(0, len(offsets), batch_size):
        batch = offsets[first : first + batch_size]
        rolled = [
            jnp.stack(r)
            for r in zip(*(_rolled(coordinates, o, n_cells, lengths) for o in batch), strict=True)
        ]
        # Within the own cell (offset 0) only slot pairs i < j count.
        is_own = np.array([offset == (0, 0, 0) for offset in batch])[:, None, None]
        counted = ~is_own | (slot_index[:, None] < slot_index[None, :])[None]
        batch_words = [jnp.zeros((len(batch),) + grid_shape, jnp.uint32) for _ in range(groups)]
        for j in range(cell_capacity):
            # Slot j of each neighbour cell against all slots of the own cell.
            separation = []
            for axis in range(3):
                component = coordinates[axis][None] - rolled[axis][:, j, None]
                if n_cells[axis] == 1:
                    length = jnp.asarray(lengths[axis], dtype)
                    component = component - length * jnp.round(component / length)
                separation.append(component)
            separation = bound_box.frame_to_cartesian(tuple(separation))
            distance_sq = separation[0] ** 2 + separation[1] ** 2 + separation[2] ** 2
            within = (distance_sq < limit) & counted[:, :, j, None, None, None]
            group, bit = divmod(j, WORD_BITS)
            batch_words[group] = batch_words[group] | (within.astype(jnp.uint32) << jnp.uint32(bit))
        # (batch, groups, slots, grid): word index offset · groups + group.
        words.append(jnp.stack(batch_words, axis=1).reshape((-1, cell_capacity) + n_cells))
    return jnp.concatenate(words).reshape(len(offsets) * groups, cell_capacity, -1)


def _rolled(coordinates, offset, n_cells, lengths):
    """Coordinates of the slots of each cell's neighbour (cell + offset), per axis.

    Cells whose neighbour wrapped around the grid see it one box length away.
    """
    rolled = []
    for axis in range(3):
        neighbor = jnp.roll(coordinates[axis], tuple(-o for o in offset), axis=(1, 2, 3))
        if offset[axis] != 0:
            edge = n_cells[axis] - 1 if offset[axis] > 0 else 0
            index = jnp.arange(n_cells[axis]).reshape(
                [n_cells[axis] if a == axis else 1 for a in range(3)]
            )
            image = jnp.where(index == edge, offset[axis] * lengths[axis], 0.0)
            neighbor = neighbor + image.astype(neighbor.dtype)[None]
        rolled.append(neighbor)
    return rolled


def _compact(accepted, pair_capacity: int):
    """Locate the set bits of `accepted` (words × rows) in row-major order.

    Every (row, word) entry owns a run of output slots as long as its popcount,
    starting at the exclusive prefix sum of the popcounts in row-major order.  Each
    non-empty entry writes its index at its start slot, and a cumulative maximum
    carries it over the run: slot p belongs to the last entry starting at or before
    it.  The bit is then the rank-th set bit of that entry's word, found by a
    five-step binary search over popcounts of bit prefixes (register arithmetic).
    Everything is O(entries + capacity), with no search over the rows.

    Returns:
        row, word, bit: (pair_capacity,) int32 locations.
        valid: (pair_capacity,) bool, p < total.
        total: int32 number of set bits (may exceed the capacity).
    """
    words, rows = accepted.shape
    entries = accepted.T.reshape(-1)  # row-major: entry e = row · words + word
    counts = jax.lax.population_count(entries).astype(jnp.int32)
    inclusive = jnp.cumsum(counts, dtype=jnp.int32)
    starts = inclusive - counts
    total = inclusive[-1]
    index = jnp.arange(entries.shape[0], dtype=jnp.int32)
    # Empty entries and runs beyond the capacity write nowhere (index dropped).
    target = jnp.where((counts > 0) & (starts < pair_capacity), starts, pair_capacity)
    owner = jnp.zeros(pair_capacity, jnp.int32).at[target].max(index, mode="drop")
    owner = jax.lax.cummax(owner)
    slots = jnp.arange(pair_capacity, dtype=jnp.int32)
    rank = slots - starts[owner]
    bits = entries[owner]

    def set_bits_up_to(k):
        prefix = (jnp.uint32(2) << k.astype(jnp.uint32)) - jnp.uint32(1)
        return jax.lax.population_count(bits & prefix).astype(jnp.int32)

    bit = jnp.minimum(_lower_bound(set_bits_up_to, WORD_BITS, rank + 1), WORD_BITS - 1)
    return owner // words, owner % words, bit, slots < total, total


def cell_list_search(box, n_particles: int, cutoff: float, skin: float):
    """jaxdpd's cell-list half neighbour list (see the module docstring).

    Args:
        box: a static box (periodic or flowing); requires its `cell_heights` to exceed
            2 (cutoff + skin).
        n_particles: N.
        cutoff: interaction cut-off r_c.
        skin: Verlet skin ≥ 0.
    Returns:
        NeighborSearch with half = True.
    """
    list_cutoff = cutoff + skin
    n_cells = cell_grid(box, list_cutoff)
    n_cells_total = math.prod(n_cells)
    cell_size = tuple(length / n for length, n in zip(box.lengths, n_cells, strict=True))

    offsets = stencil(n_cells)
    offset_table = jnp.asarray(offsets, jnp.int32)

    def build(positions, box_state, cell_capacity: int, pair_capacity: int) -> PairList:
        bound_box = box.bind(box_state)
        frame = bound_box.frame_positions(positions)
        cell_xyz = _cell_coordinates(frame, cell_size, n_cells)
        cell_ids = _cell_id(cell_xyz, n_cells)
        members, slot, max_occupancy = _bin(cell_ids, n_cells_total, cell_capacity)
        grid_words = _accepted_words(bound_box, frame, members, n_cells, offsets, list_cutoff)
        # Each particle's row of words: (words, N).
        accepted = grid_words[:, jnp.minimum(slot, cell_capacity - 1), cell_ids]
        accepted = jnp.where(slot < cell_capacity, accepted, jnp.uint32(0))
        i, word, bit, valid, total = _compact(accepted, pair_capacity)
        groups = math.ceil(cell_capacity / WORD_BITS)
        partner_slot = jnp.minimum((word % groups) * WORD_BITS + bit, cell_capacity - 1)
        neighbor_xyz = (cell_xyz[i] + offset_table[word // groups]) % jnp.asarray(n_cells)
        partner = members[partner_slot, _cell_id(neighbor_xyz, n_cells)]
        return PairList(
            i=jnp.where(valid, i, n_particles),
            j=jnp.where(valid, partner, n_particles),
            reference_positions=positions,
            reference_box_state=box_state,
            needed_pairs=total,
            needed_cell_occupancy=max_occupancy,
            overflow=(total > pair_capacity) | (max_occupancy > cell_capacity),
            rebuilds=jnp.asarray(0, jnp.int32),
            cell_capacity=cell_capacity,
        )

    build_jit = jax.jit(build, static_argnums=(2, 3))

    @jax.jit
    def fullest_cell(positions, box_state):
        """Occupancy of the fullest cell (sizes the cell buffers)."""
        frame = box.bind(box_state).frame_positions(positions)
        ids = _cell_id(_cell_coordinates(frame, cell_size, n_cells), n_cells)
        return jnp.max(jnp.zeros(n_cells_total, jnp.int32).at[ids].add(1))

    def allocate(
        positions, capacity_multiplier: float = 1.25, minimum=None, box_state=None
    ) -> PairList:
        """Size the buffers for `positions` (outside jit), then build the list.

        The pair buffer starts from the ideal-gas estimate ½N(N−1)·(4π/3)r_list³/V
        and is re-sized once if the configuration holds more pairs.

        Args:
            positions: (N, 3) wrapped positions.
            capacity_multiplier: head-room factor (≥ 1) on the counts found.
            minimum: optional (pairs, cell occupancy) the buffers must at least hold,
                e.g. the needs recorded when a chunk overflowed.
            box_state: the box state of a flowing box (None at rest).
        """
        min_pairs, min_occupancy = minimum or (0, 0)
        occupancy = max(int(fullest_cell(positions, box_state)), int(min_occupancy))
        cell_capacity = occupancy + max(3, math.ceil(0.2 * occupancy))
        ideal = 0.5 * n_particles * (n_particles - 1) * 4 / 3 * math.pi * list_cutoff**3
        pairs = max(ideal / box.volume, int(min_pairs))
        capacity = max(16, math.ceil(pairs * capacity_multiplier))
        pair_list = build_jit(positions, box_state, cell_capacity, capacity)
        if int(pair_list.needed_pairs) > pair_list.capacity:
            needed = math.ceil(int(pair_list.needed_pairs) * capacity_multiplier)
            pair_list = build_jit(positions, box_state, cell_capacity, needed)
        return pair_list

    def update(positions, pair_list: PairList, box_state=None) -> PairList:
        def rebuild(old):
            new = build(positions, box_state, old.cell_capacity, old.capacity)
            return new.set(
                needed_pairs=jnp.maximum(new.needed_pairs, old.needed_pairs),
                needed_cell_occupancy=jnp.maximum(
                    new.needed_cell_occupancy, old.needed_cell_occupancy
                ),
                overflow=new.overflow | old.overflow,
                rebuilds=old.rebuilds + 1,
            )

        if skin == 0:
            return rebuild(pair_list)
        stale = needs_rebuild(box, positions, pair_list, box_state, skin)
        return jax.lax.cond(stale, rebuild, lambda old: old, pair_list)

    return NeighborSearch(allocate=allocate, update=update, half=True, cutoff=cutoff, skin=skin)
