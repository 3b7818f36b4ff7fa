"""jaxdpd's cell-list half neighbour list.

Particles are binned, by their coordinates in the box's frame (the positions
themselves in a box at rest, sheared coordinates in a Lees–Edwards box; see
jaxdpd.geometry.boxes), into cells at least r_c + skin thick and laid out on a padded grid
(slot, c_x, c_y, c_z) of per-cell member slots.  Each cell is compared with itself
(slot pairs j > i) and with 13 "forward" neighbour cells (a half stencil), so every
pair is found exactly once.  The grid is padded with a layer of periodic images
and flattened, so that each offset's neighbour cells are one static slice of it, and
the distance tests are dense element-wise arithmetic on contiguous (slot, cell)
planes: XLA's CPU backend vectorises these, unlike per-particle gathers of
candidates.  Each test result is one bit per candidate slot, in lanes of up to 32
slots, and the lanes of a particle's row are packed, as many as fit, into 64-bit
words (a row of the 14 offsets × 5 dense-tier slots of a DPD fluid at ρ = 3 needs
2 words, not 14).  The accepted
pairs are compacted into flat (i, j) arrays with prefix sums over popcounts, one
scatter and a running maximum (O(N + capacity), no per-pair search over the rows).

The dense test costs (stencil offsets) × (slots)² per cell, while a liquid fills
its cells far below the capacity that its fullest cell needs (ρ = 3 DPD at
N = 24000: 3 on average, 7 at most among 8000 cells, capacity 11).  Only the lowest
⌈m + √m⌉ slots (m the mean occupancy; the "dense tier", 5 of 11 there) take part in
it; the few particles in the slots above (0.37 % of that liquid) are "crowded", and each is
tested, by gathers, against every slot of its 27 surrounding cells (pairs of two
crowded particles from the lower index only).  This quarters the dense work.

The tier depends on N and the grid only, never on the buffer sizes, so the pairs
and their order (dense-tier rows by particle, then crowded rows by particle) are a
function of the positions alone, and a run whose buffers are reallocated stays
bit-identical to one whose buffers never changed.  The number of crowded particles
the buffers hold grows with the cell capacity (`crowd_capacity`); more than that
flag an overflow that asks for larger cells (`needed_cell_occupancy`).

With `absent_rows`, a row whose frame coordinates are not finite is absent: it is
binned into no cell and takes part in no pair (the free rows of a device's buffers in
a decomposed run, jaxdpd.decomposition); without it none of this is traced.

Axes with fewer than three cells fall back to a single cell along that axis (every
particle is a candidate along it, measured by the minimum image in the frame, which
stays unique because the scene requires every cell height > 2 (r_c + skin)).  A
dilute box gets larger cells, at most 4 per particle (`cell_grid`), so that the grid
stays O(N) however large the box.
"""

import itertools
import math

import jax
import jax.numpy as jnp
import numpy as np

from jaxdpd.geometry.neighbors.pair_list import NeighborSearch, PairList, needs_rebuild
from jaxdpd.precision import enable_float64
from jaxdpd.scatter import nonzero_indices

LANE_BITS = 32  # candidate slots per distance-test lane (uint32)
WORD_BITS = 64  # bits per packed row word (uint64)
CELLS_PER_PARTICLE = 4  # most cells per particle of the grid (`cell_grid`)


def _running(op, values):
    """Inclusive running `op` (jnp.add or jnp.maximum) along a 1-D array.

    `jax.lax.associative_scan` rather than jnp.cumsum or lax.cummax: on XLA's CPU
    backend it ran 2× (sum) and 4–5× (maximum) faster on 10⁵–10⁶ int32 entries
    (measured in this project on 2 cores), and it is exact for integers.
    """
    return jax.lax.associative_scan(op, values)


def cell_grid(box, list_cutoff: float, n_particles: int | None = None) -> tuple[int, int, int]:
    """Cells per frame axis: ⌊h/r_list⌋ with h the box's thinnest extent along that
    axis (`box.cell_heights`: the edge of a box at rest), or 1 where that would be
    fewer than 3.

    Given `n_particles`, a dilute box gets fewer, larger cells: the axis with the most
    cells is halved until the grid has at most CELLS_PER_PARTICLE · N cells (27 at
    least), so that the grid's memory and the work per step stay O(N) however large
    the box (600 particles in a box of 5.85 × 10⁷ × 5.85 would otherwise need
    2.5·10⁸ cells). Larger cells only add candidates that the distance test rejects.
    """
    counts = []
    for height in box.cell_heights:
        n = int(math.floor(height / list_cutoff))
        counts.append(n if n >= 3 else 1)
    if n_particles is not None:
        limit = max(CELLS_PER_PARTICLE * n_particles, 27)
        while math.prod(counts) > limit:
            axis = counts.index(max(counts))
            halved = counts[axis] // 2
            counts[axis] = halved if halved >= 3 else 1
    return tuple(counts)


def full_stencil(n_cells: tuple[int, int, int]) -> list[tuple[int, int, int]]:
    """All offsets of {−1, 0, 1}³ (only 0 along single-cell axes): the cells around
    a cell, each met once (the grid has ≥ 3 cells per axis)."""
    return list(itertools.product(*[(-1, 0, 1) if n >= 3 else (0,) for n in n_cells]))


def stencil(n_cells: tuple[int, int, int]) -> list[tuple[int, int, int]]:
    """The own cell (0, 0, 0) followed by the lexicographically positive offsets of
    `full_stencil`: every unordered pair of distinct cells is visited from exactly
    one side."""
    return [(0, 0, 0)] + [o for o in full_stencil(n_cells) if o > (0, 0, 0)]


def _select_bit(words, rank):
    """Position of the set bit of each 64-bit word that has `rank` (0-based) set bits
    below it: a branch-free halving search over popcounts (widths 32, 16, …, 1),
    unrolled into elementwise arithmetic on 32-bit halves.

    Args:
        words: uint64 array.
        rank: int32 array of the same shape, 0 ≤ rank < popcount(words).
    """
    low = (words & jnp.uint64(0xFFFFFFFF)).astype(jnp.uint32)
    below = jax.lax.population_count(low).astype(jnp.int32)
    upper = rank >= below
    half = jnp.where(upper, (words >> jnp.uint64(32)).astype(jnp.uint32), low)
    rank = jnp.where(upper, rank - below, rank)
    position = jnp.where(upper, jnp.int32(32), jnp.int32(0))
    for width in (16, 8, 4, 2, 1):
        below = jax.lax.population_count(half & jnp.uint32((1 << width) - 1)).astype(jnp.int32)
        upper = rank >= below
        rank = jnp.where(upper, rank - below, rank)
        half = jnp.where(upper, half >> jnp.uint32(width), half)
        position = jnp.where(upper, position + width, position)
    return position


def _cell_coordinates(positions, cell_size, n_cells):
    """Integer cell coordinates (c_x, c_y, c_z) of each particle, (N, 3) int32."""
    cell_xyz = jnp.floor(positions / jnp.asarray(cell_size, positions.dtype)).astype(jnp.int32)
    return jnp.clip(cell_xyz, 0, jnp.asarray(n_cells, jnp.int32) - 1)


def _cell_id(cell_xyz, n_cells):
    """Cell id (c_x n_y + c_y) n_z + c_z from integer coordinates (..., 3)."""
    return (cell_xyz[..., 0] * n_cells[1] + cell_xyz[..., 1]) * n_cells[2] + cell_xyz[..., 2]


def _binned_cell_id(frame, cell_xyz, n_cells):
    """Each particle's cell id, or the number of cells (no cell) for an absent row:
    one whose frame coordinates are not finite (the padding of a domain's buffers,
    jaxdpd.decomposition)."""
    present = jnp.all(jnp.isfinite(frame), axis=1)
    return jnp.where(present, _cell_id(cell_xyz, n_cells), math.prod(n_cells))


def _bin(cell_ids, n_cells_total: int, cell_capacity: int, absent_rows: bool = False):
    """Sort particles into per-cell slots (`absent_rows`: some cell ids are
    n_cells_total, rows binned into no cell; `_binned_cell_id`).

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
    if absent_rows:
        # Absent rows sort last, are counted in no cell and get slot cell_capacity:
        # in no slot of the grid.
        counts = jnp.zeros(n_cells_total, jnp.int32).at[cell_ids].add(1, mode="drop")
        starts = _running(jnp.add, counts) - counts
        ordered = cell_ids[order]
        rank = jnp.arange(n, dtype=jnp.int32) - starts[jnp.minimum(ordered, n_cells_total - 1)]
        rank = jnp.where(ordered < n_cells_total, rank, cell_capacity)
    else:
        counts = jnp.zeros(n_cells_total, jnp.int32).at[cell_ids].add(1)
        starts = _running(jnp.add, counts) - counts
        rank = jnp.arange(n, dtype=jnp.int32) - starts[cell_ids[order]]
    slot = jnp.zeros(n, jnp.int32).at[order].set(rank)
    slots = jnp.arange(cell_capacity, dtype=jnp.int32)[:, None]
    gathered = order[jnp.clip(starts[None, :] + slots, 0, n - 1)]
    return jnp.where(slots < counts[None, :], gathered, n), slot, jnp.max(counts)


def _materialised(predicate, compute, *operands):
    """`compute(*operands)` where `predicate` holds, else zeros of its shape, as a
    computation of its own (the branch of a conditional).  XLA fuses a cheap producer
    into each consumer, and into a gather it then re-evaluates it element by element
    in scalar code; its CPU pipeline drops optimisation barriers, so a conditional is
    what keeps such a result materialised."""
    shape = jax.eval_shape(compute, *operands)

    def zeros(*_):
        return jax.tree.map(lambda x: jnp.zeros(x.shape, x.dtype), shape)

    return jax.lax.cond(predicate, compute, zeros, *operands)


def halo_grid(n_cells: tuple[int, int, int]) -> dict:
    """The cell grid padded with one layer of periodic images on every axis of ≥ 3
    cells, flattened (static numpy tables).

    On the padded grid the neighbour (cell + offset) of every interior cell sits at
    one fixed distance in the flat index, so a stencil offset's neighbour slots are a
    static slice: the distance tests read contiguous memory, which XLA's CPU loops
    vectorise (rolling the grid instead made them gather).

    Returns:
        {"source": (P,) the cell each padded cell copies, "image": (P, 3) its image
        (−1, 0, 1) along each axis, "strides": flat strides of the padded axes,
        "first": flat index of the first interior cell, "span": flat length from the
        first to the last interior cell, "index": (cells,) each cell's place in that
        span}.
    """
    pads = np.asarray([1 if n >= 3 else 0 for n in n_cells])
    shape = np.asarray(n_cells)
    padded = shape + 2 * pads
    xyz = np.indices(padded).reshape(3, -1).T - pads
    strides = np.asarray([padded[1] * padded[2], padded[2], 1])
    interior = (np.indices(n_cells).reshape(3, -1).T + pads) @ strides
    first = int(interior.min())
    return {
        "source": _cell_id(xyz % shape, n_cells).astype(np.int32),
        "image": np.floor_divide(xyz, shape),
        "strides": tuple(int(s) for s in strides),
        "first": first,
        "span": int(interior.max()) + 1 - first,
        "index": (interior - first).astype(np.int32),
    }


def halo_deltas(halo: dict, offsets) -> np.ndarray:
    """Flat-index distance from a cell to its neighbour at each offset on the padded
    grid of `halo_grid` (int64; may be negative)."""
    return np.asarray(
        [sum(o * s for o, s in zip(offset, halo["strides"], strict=True)) for offset in offsets]
    )


def _dense_words(bound_box, frame, padded_members, n_cells, offsets, list_cutoff, halo):
    """Distance tests of every dense-tier slot against the dense-tier slots of its
    stencil cells, packed into 64-bit words (layout of `_lane_layout`: lane
    o · groups + g holds slots g·32 … of the cell at offset o).

    Args:
        bound_box: the box at this instant (frame lengths, frame → Cartesian).
        frame: (N, 3) frame coordinates of the particles.
        padded_members: (slots, P) particle in each dense-tier slot of each cell of
            the padded grid (N when empty).
        offsets: the stencil, own cell first.
        halo: `halo_grid(n_cells)`.
    Returns:
        (words, slots, span) uint64 over the flat padded grid's interior span (a
        cell's column is `halo["index"]`).
    """
    n = frame.shape[0]
    dtype = frame.dtype
    lengths = bound_box.lengths
    dense = padded_members.shape[0]
    empty = padded_members >= n
    safe = jnp.minimum(padded_members, n - 1)
    # Empty slots hold NaN: every comparison with them is False.  Image cells are
    # shifted by a box length along the frame axis they wrapped.
    coordinates = []
    for axis in range(3):
        values = jnp.where(empty, jnp.asarray(jnp.nan, dtype), frame[:, axis][safe])
        if n_cells[axis] >= 3:
            image = halo["image"][:, axis] * lengths[axis]
            values = values + jnp.asarray(image, dtype)[None]
        coordinates.append(values)
    first, span = halo["first"], halo["span"]
    own = [values[:, first : first + span] for values in coordinates]
    limit = jnp.asarray(list_cutoff**2, dtype)
    groups, lane_width, per_word = _lane_layout(dense)
    n_lanes = len(offsets) * groups
    offset_starts = first + halo_deltas(halo, offsets)  # each offset's slice start
    slot_index = np.arange(dense)[None, :, None]
    words = []
    for first_lane in range(0, n_lanes, per_word):
        word = jnp.zeros((dense, span), jnp.uint64)
        for position, lane in enumerate(range(first_lane, min(first_lane + per_word, n_lanes))):
            offset_index, group = divmod(lane, groups)
            offset = offsets[offset_index]
            start = int(offset_starts[offset_index])
            # The lane's candidate slots j along a leading axis, (bits, dense, span):
            # traced once per lane, not per slot, so that the program (and its compile
            # time) grows with the lanes.  The bits are OR-ed slice by slice, which XLA
            # fuses as fast as per-slot code (a reduce over the axis ran slower).
            j = np.arange(group * LANE_BITS, min((group + 1) * LANE_BITS, dense))
            separation = []
            for axis in range(3):
                neighbor = coordinates[axis][j[0] : j[-1] + 1, start : start + span]
                component = own[axis][None] - neighbor[:, None]
                if n_cells[axis] == 1:
                    length = jnp.asarray(lengths[axis], dtype)
                    component = component - length * jnp.round(component / length)
                separation.append(component)
            separation = bound_box.frame_to_cartesian(tuple(separation))
            distance_sq = separation[0] ** 2 + separation[1] ** 2 + separation[2] ** 2
            within = distance_sq < limit
            if offset == (0, 0, 0):  # within the own cell only slot pairs i < j count
                within = within & (slot_index < j[:, None, None])
            shifts = jnp.asarray(position * lane_width + j - j[0], jnp.uint64)[:, None, None]
            bits = within.astype(jnp.uint64) << shifts
            for k in range(len(j)):
                word = word | bits[k]
        words.append(word)
    return jnp.stack(words)


def dense_tier(n_particles: float, n_cells_total: int) -> int:
    """Slots per cell that take part in the dense test: ⌈m + √m⌉ for a mean
    occupancy m = n_particles / n_cells_total (a Poisson fluctuation above the
    mean; see the module docstring)."""
    mean = n_particles / n_cells_total
    return max(1, math.ceil(mean + math.sqrt(mean)))


def crowd_capacity(n_particles: int, cell_capacity: int, dense: int) -> int:
    """How many particles the buffers hold above the dense tier: ⌈N/200⌉ + 32 while
    the cell capacity is at most twice the tier, one more such share for every slot
    beyond (so an overflow's larger cells make room), and at most N."""
    shares = max(1, cell_capacity - 2 * dense + 1)
    return min(n_particles, (math.ceil(n_particles / 200) + 32) * shares)


def _crowded_rows(bound_box, frame, members, slot, around_cells, list_cutoff, dense):
    """Candidate tests of the crowded particles (slots at or above the dense tier).

    Each crowded particle p is tested against every slot of the cells of
    `full_stencil` around its own: dense-tier partners always (the dense test never
    sees p), crowded partners q only when p < q, so each pair is found once.

    Args:
        members: (slots, cells) particle in each slot (N when empty).
        slot: (N,) each particle's slot in its cell.
        around_cells: `around_cells(p)` -> (..., offsets) cell ids of the cells of
            `full_stencil` around particles p.
        dense: slots in the dense tier.
    Returns:
        crowded: (K,) crowded particles in index order (N in unused rows), K =
            `crowd_capacity`.
        count: int32 number of crowded particles (may exceed K).
        words: (words, K) uint64: candidate c = o · slots + s (slot s of the cell at
            offset o of the full stencil) is bit c mod 64 of word ⌊c/64⌋.
    """
    n = frame.shape[0]
    cell_capacity = members.shape[0]
    is_crowded = (slot >= dense) & (slot < cell_capacity)
    room = crowd_capacity(n, cell_capacity, dense)
    crowded = nonzero_indices(is_crowded, room, n).astype(jnp.int32)
    count = jnp.sum(is_crowded, dtype=jnp.int32)

    def gathered():
        """Whole cells gathered as rows: partners (K, offsets, slots) and raw
        separations (K, offsets, slots, 3), kept apart from the tests that follow
        so that those run as vector loops."""
        safe = jnp.minimum(crowded, n - 1)
        cells = around_cells(safe)
        slot_frames = frame[jnp.minimum(members.T, n - 1)]
        return members.T[cells], frame[safe][:, None, None, :] - slot_frames[cells]

    # A small system's step often has no crowded particle at all.
    partners, separation = _materialised(count > 0, gathered)
    lengths = jnp.asarray(bound_box.lengths, frame.dtype)
    separation = separation - lengths * jnp.round(separation / lengths)
    separation = [separation[..., axis] for axis in range(3)]
    separation = bound_box.frame_to_cartesian(tuple(separation))
    distance_sq = separation[0] ** 2 + separation[1] ** 2 + separation[2] ** 2
    own = crowded[:, None, None]
    partner_dense = np.arange(cell_capacity) < dense
    counted = (own < n) & (partners < n) & (partners != own) & (partner_dense | (own < partners))
    within = (distance_sq < jnp.asarray(list_cutoff**2, frame.dtype)) & counted
    flat = within.reshape(within.shape[0], -1)
    n_words = math.ceil(flat.shape[1] / WORD_BITS)
    flat = jnp.pad(flat, ((0, 0), (0, n_words * WORD_BITS - flat.shape[1])))
    weights = jnp.left_shift(jnp.uint64(1), jnp.arange(WORD_BITS, dtype=jnp.uint64))
    # Distinct powers of two: their sum is their bitwise or.
    words = jnp.sum(flat.reshape(-1, n_words, WORD_BITS) * weights, axis=-1, dtype=jnp.uint64)
    return crowded, count, words.T


def _lane_layout(cell_capacity: int) -> tuple[int, int, int]:
    """(lanes per offset, bits per lane, lanes per 64-bit word) for a capacity."""
    groups = math.ceil(cell_capacity / LANE_BITS)
    lane_width = cell_capacity if groups == 1 else LANE_BITS
    return groups, lane_width, WORD_BITS // lane_width


def _compact(entries, pair_capacity: int):
    """Locate the set bits of the 64-bit `entries` in order.

    Every entry owns a run of output slots as long as its popcount, starting at the
    exclusive prefix sum of the popcounts.  Each non-empty entry writes its index at
    its start slot, and a running maximum carries it over the run: slot p belongs to
    the last entry starting at or before it.  The bit is then the rank-th set bit of
    that entry (`_select_bit`, register arithmetic).  Everything is
    O(entries + capacity), with no search over the rows.

    Returns:
        entry, bit: (pair_capacity,) int32 locations.
        valid: (pair_capacity,) bool, p < total.
        total: int32 number of set bits (may exceed the capacity).
    """
    counts = jax.lax.population_count(entries).astype(jnp.int32)
    inclusive = _running(jnp.add, counts)
    starts = inclusive - counts
    total = inclusive[-1]
    index = jnp.arange(entries.shape[0], dtype=jnp.int32)
    # Empty entries and runs beyond the capacity write nowhere (index dropped).
    target = jnp.where((counts > 0) & (starts < pair_capacity), starts, pair_capacity)
    owner = jnp.zeros(pair_capacity, jnp.int32).at[target].max(index, mode="drop")
    owner = _running(jnp.maximum, owner)
    slots = jnp.arange(pair_capacity, dtype=jnp.int32)
    rank = slots - starts[owner]
    # The search runs in its own computation (the branch of a data-dependent cond):
    # fused with the gathers of the decoding that follows, XLA made one scalar loop of
    # it that ran 5–10× slower, and XLA's CPU pipeline drops optimisation barriers.
    bit = jax.lax.cond(
        total > 0,
        lambda: _select_bit(entries[owner], rank),
        lambda: jnp.zeros_like(rank),
    )
    return owner, bit, slots < total, total


def cell_list_search(
    box,
    n_particles: int,
    cutoff: float,
    skin: float,
    absent_rows: bool = False,
    density: float | None = None,
):
    """jaxdpd's cell-list half neighbour list (see the module docstring).

    Args:
        box: a static box (periodic or flowing); requires its `cell_heights` to exceed
            2 (cutoff + skin).
        n_particles: N.
        cutoff: interaction cut-off r_c.
        skin: Verlet skin ≥ 0.
        absent_rows: rows with non-finite coordinates are absent (module docstring);
            False traces none of that test.
        density: the number density the dense tier and the cell grid's cap
            (`cell_grid`) are sized for (default N over the box volume).  A device's
            view in a decomposed run holds free rows and an empty gap beside its
            particles, so its row count overstates the density.
    Returns:
        NeighborSearch with half = True.
    """
    enable_float64()  # rows are packed into uint64 words
    list_cutoff = cutoff + skin
    expected = n_particles if density is None else density * box.volume
    n_cells = cell_grid(box, list_cutoff, math.ceil(expected))
    n_cells_total = math.prod(n_cells)
    cell_size = tuple(length / n for length, n in zip(box.lengths, n_cells, strict=True))

    offsets = stencil(n_cells)
    around = full_stencil(n_cells)
    halo = halo_grid(n_cells)
    halo_source = jnp.asarray(halo["source"])
    halo_index = jnp.asarray(halo["index"])
    stencil_deltas = jnp.asarray(halo_deltas(halo, offsets), jnp.int32)
    around_deltas = jnp.asarray(halo_deltas(halo, around), jnp.int32)
    dense_slots = dense_tier(expected, n_cells_total)

    def build(positions, box_state, cell_capacity: int, pair_capacity: int) -> PairList:
        bound_box = box.bind(box_state)
        frame = bound_box.frame_positions(positions)
        cell_xyz = _cell_coordinates(frame, cell_size, n_cells)
        if absent_rows:
            cell_ids = _binned_cell_id(frame, cell_xyz, n_cells)
        else:
            cell_ids = _cell_id(cell_xyz, n_cells)
        members, slot, max_occupancy = _bin(cell_ids, n_cells_total, cell_capacity, absent_rows)
        dense = min(dense_slots, cell_capacity)
        padded_members = members[:, halo_source]  # (slots, P): the grid with its images
        grid_words = _materialised(
            max_occupancy > 0,
            lambda: _dense_words(
                bound_box, frame, padded_members[:dense], n_cells, offsets, list_cutoff, halo
            ),
        )
        # Each dense-tier particle's row of words: (words, N).
        cells = jnp.minimum(cell_ids, n_cells_total - 1) if absent_rows else cell_ids
        span_index = halo_index[cells]  # column of each particle's cell in the words
        dense_rows = grid_words[:, jnp.minimum(slot, dense - 1), span_index]
        dense_rows = jnp.where(slot < dense, dense_rows, jnp.uint64(0))

        def padded_cell(particles):
            """Flat padded-grid index of each particle's cell."""
            return halo["first"] + span_index[particles]

        def around_cells(particles):
            return halo_source[padded_cell(particles)[..., None] + around_deltas]

        crowded, crowd, crowded_rows = _crowded_rows(
            bound_box, frame, members, slot, around_cells, list_cutoff, dense
        )
        dense_entries = dense_rows.size
        entry, bit, valid, total = _compact(
            jnp.concatenate([dense_rows.T.reshape(-1), crowded_rows.T.reshape(-1)]), pair_capacity
        )
        # Each accepted bit names a row particle and a candidate c = (offset, slot)
        # of the cells around it: on the padded grid the cell at offset o lies
        # `deltas[o]` further along the flat index, so the partner is one lookup.
        # Unsigned arithmetic: every index here is ≥ 0.
        is_dense = entry < dense_entries
        entry, bit = entry.astype(jnp.uint32), bit.astype(jnp.uint32)
        n_dense_words, n_crowded_words = dense_rows.shape[0], crowded_rows.shape[0]
        groups, lane_width, per_word = _lane_layout(dense)
        dense_row = entry // n_dense_words
        dense_candidate = (entry - dense_row * n_dense_words) * (per_word * lane_width) + bit
        crowded_entry = jnp.where(is_dense, jnp.uint32(0), entry - dense_entries)
        crowded_row = crowded_entry // n_crowded_words
        crowded_candidate = (crowded_entry - crowded_row * n_crowded_words) * WORD_BITS + bit
        row_slots = lane_width * groups  # candidates per stencil offset of a dense row
        i = jnp.where(is_dense, dense_row.astype(jnp.int32), crowded[crowded_row])
        partner_slot = jnp.where(
            is_dense, dense_candidate % row_slots, crowded_candidate % cell_capacity
        )
        delta = jnp.where(
            is_dense,
            stencil_deltas[jnp.minimum(dense_candidate // row_slots, len(offsets) - 1)],
            around_deltas[jnp.minimum(crowded_candidate // cell_capacity, len(around) - 1)],
        )
        row_cell = padded_cell(jnp.minimum(i, n_particles - 1))
        partner = padded_members[jnp.minimum(partner_slot, cell_capacity - 1), row_cell + delta]
        # Too many crowded particles: ask for larger cells, which hold more of them.
        crowd_overflow = crowd > crowded.shape[0]
        needed_occupancy = jnp.where(
            crowd_overflow, jnp.maximum(max_occupancy, cell_capacity + 1), max_occupancy
        )
        return PairList(
            i=jnp.where(valid, i, n_particles),
            j=jnp.where(valid, partner, n_particles),
            reference_positions=positions,
            reference_box_state=box_state,
            needed_pairs=total,
            needed_cell_occupancy=needed_occupancy,
            overflow=(total > pair_capacity) | (needed_occupancy > cell_capacity),
            rebuilds=jnp.asarray(0, jnp.int32),
            cell_capacity=cell_capacity,
        )

    build_jit = jax.jit(build, static_argnums=(2, 3))

    @jax.jit
    def occupancies(positions, box_state):
        """Particles in each cell (sizes the cell buffers)."""
        frame = box.bind(box_state).frame_positions(positions)
        cell_xyz = _cell_coordinates(frame, cell_size, n_cells)
        if absent_rows:
            ids = _binned_cell_id(frame, cell_xyz, n_cells)
            return jnp.zeros(n_cells_total, jnp.int32).at[ids].add(1, mode="drop")
        return jnp.zeros(n_cells_total, jnp.int32).at[_cell_id(cell_xyz, n_cells)].add(1)

    def fit(
        positions, capacity_multiplier: float = 1.25, minimum=None, box_state=None
    ) -> tuple[int, int]:
        """(pair capacity, cell capacity) for `positions` (outside jit), built from
        the cell occupancies alone.

        The pair buffer starts from the ideal-gas estimate ½N(N−1)·(4π/3)r_list³/V;
        the cell buffer holds the fullest cell with a fifth (at least 3 slots) to
        spare, and enough slots that the crowded particles fill at most half the
        room kept for them.

        Args:
            positions: (N, 3) wrapped positions.
            capacity_multiplier: head-room factor (≥ 1) on the pair count.
            minimum: optional (pairs, cell occupancy) the buffers must at least hold,
                e.g. the needs recorded when a chunk overflowed.
            box_state: the box state of a flowing box (None at rest).
        """
        min_pairs, min_occupancy = minimum or (0, 0)
        counts = np.asarray(occupancies(positions, box_state))
        occupancy = max(int(counts.max()), int(min_occupancy))
        cell_capacity = occupancy + max(3, math.ceil(0.2 * occupancy))
        # Leave the crowded particles (above the dense tier) half their room to grow.
        crowd = np.maximum(counts - dense_slots, 0).sum()
        room = crowd_capacity(n_particles, cell_capacity, dense_slots)
        while crowd > room / 2 and room < n_particles:
            cell_capacity += 1
            room = crowd_capacity(n_particles, cell_capacity, dense_slots)
        ideal = 0.5 * n_particles * (n_particles - 1) * 4 / 3 * math.pi * list_cutoff**3
        pairs = max(ideal / box.volume, int(min_pairs))
        return max(16, math.ceil(pairs * capacity_multiplier)), cell_capacity

    def allocate(
        positions, capacity_multiplier: float = 1.25, minimum=None, box_state=None
    ) -> PairList:
        """Size the buffers for `positions` (outside jit, see `fit`), then build the
        list, re-sized once if the configuration holds more pairs than estimated."""
        capacity, cell_capacity = fit(positions, capacity_multiplier, minimum, box_state)
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

    return NeighborSearch(
        allocate=allocate, update=update, half=True, cutoff=cutoff, skin=skin, fit=fit
    )
