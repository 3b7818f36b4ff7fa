"""jaxdpd's cell-list half neighbour list.

Particles are binned into cells of side ≥ r_c + skin; each particle looks at the
members of its own cell with a larger index and at all members of 13 "forward"
neighbour cells (a half stencil), so each pair is found exactly once.  Candidate
coordinates are handled component by component (structure of arrays), which XLA's
CPU backend vectorises far better than (…, 3) arrays.  Accepted pairs are compacted
into flat (i, j) arrays with two branch-free binary searches instead of a scatter.

Axes with fewer than three cells fall back to a single cell along that axis (every
particle is a candidate along it); the minimum image stays unique because the scene
requires L > 2 (r_c + skin).
"""

import itertools
import math

import jax
import jax.numpy as jnp
import numpy as np

from jaxdpd.boxes import PeriodicBox
from jaxdpd.neighbors.pair_list import NeighborSearch, PairList, needs_rebuild


def cell_grid(box: PeriodicBox, list_cutoff: float) -> tuple[int, int, int]:
    """Cells per axis: ⌊L/r_list⌋, or 1 where that would be fewer than 3."""
    counts = []
    for length in box.lengths:
        n = int(math.floor(length / list_cutoff))
        counts.append(n if n >= 3 else 1)
    return tuple(counts)


def forward_neighbor_cells(n_cells: tuple[int, int, int]) -> tuple[np.ndarray, np.ndarray]:
    """For every cell, its forward (half-stencil) neighbour cells and their images.

    A cell id is (c_x n_y + c_y) n_z + c_z.  The offsets are those of {−1, 0, 1}³
    (only 0 along single-cell axes) that are lexicographically positive, so every
    unordered pair of distinct cells is visited from exactly one side.

    Returns:
        ids: (n_cells_total, n_offsets) int32 neighbour cell ids.
        images: (3, n_cells_total, n_offsets) int8, the number of box lengths to add
            to a neighbour's coordinate when the offset crosses the boundary.
    """
    choices = [(-1, 0, 1) if n >= 3 else (0,) for n in n_cells]
    offsets = [o for o in itertools.product(*choices) if o > (0, 0, 0)]
    offsets = np.array(offsets, np.int64).reshape(-1, 3)
    grid = np.stack(np.meshgrid(*[np.arange(n) for n in n_cells], indexing="ij"), axis=-1).reshape(
        -1, 3
    )
    unwrapped = grid[:, None, :] + offsets[None, :, :]
    images = np.floor_divide(unwrapped, np.array(n_cells))
    neighbors = unwrapped - images * np.array(n_cells)
    _, ny, nz = n_cells
    ids = (neighbors[..., 0] * ny + neighbors[..., 1]) * nz + neighbors[..., 2]
    shape = (grid.shape[0], offsets.shape[0])
    return ids.reshape(shape).astype(np.int32), np.moveaxis(images, -1, 0).astype(np.int8)


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


def _cell_ids(positions, cell_size, n_cells):
    """Id (c_x n_y + c_y) n_z + c_z of the cell holding each particle, (N,) int32."""
    cell_xyz = jnp.floor(positions / jnp.asarray(cell_size, positions.dtype)).astype(jnp.int32)
    cell_xyz = jnp.clip(cell_xyz, 0, jnp.asarray(n_cells, jnp.int32) - 1)
    return (cell_xyz[:, 0] * n_cells[1] + cell_xyz[:, 1]) * n_cells[2] + cell_xyz[:, 2]


def _cell_members(cell_ids, n_cells_total: int, cell_capacity: int):
    """Members of each cell, slot-major and padded with N, and the fullest occupancy.

    Returns:
        members: (cell_capacity, n_cells_total) int32 particle indices.
        max_occupancy: int32 scalar.
    """
    n = cell_ids.shape[0]
    order = jnp.argsort(cell_ids).astype(jnp.int32)
    counts = jnp.zeros(n_cells_total, jnp.int32).at[cell_ids].add(1)
    starts = jnp.cumsum(counts) - counts
    slot = jnp.arange(cell_capacity, dtype=jnp.int32)[:, None]
    gathered = order[jnp.clip(starts[None, :] + slot, 0, n - 1)]
    return jnp.where(slot < counts[None, :], gathered, n), jnp.max(counts)


def _word_layout(cell_capacity: int) -> tuple[int, int]:
    """(bits per word, words per cell): a cell's slots are split into ≤ 32-bit words."""
    width = min(cell_capacity, 32)
    return width, math.ceil(cell_capacity / width)


def _candidates(box, positions, cell_size, n_cells, tables, cell_capacity, list_cutoff):
    """Candidate partners of every particle, grouped in words of ≤ 32 slots.

    Word w of particle n holds slots 0..width−1 of one (cell, slot group); bit k of
    `accepted[n, w]` says whether candidate `candidates[k, n, w]` is within r_list.
    Slot-major layout keeps the inner loops over contiguous (N, words) planes.

    Along axes with three or more cells the separation is exact from the cell
    images; along single-cell axes it is the minimum image.

    Returns:
        candidates: (width, N, words) int32 (N where empty).
        accepted: (N, words) uint32 bit masks.
        max_occupancy: int32 scalar.
    """
    n = positions.shape[0]
    width, groups = _word_layout(cell_capacity)
    cell_ids = _cell_ids(positions, cell_size, n_cells)
    members, max_occupancy = _cell_members(cell_ids, math.prod(n_cells), width * groups)
    ids, images = tables
    visited = jnp.concatenate([cell_ids[:, None], ids[cell_ids]], axis=1)  # (N, cells)
    words_per_particle = visited.shape[1] * groups

    def per_word(per_cell_slot):
        """(groups·width, cells) -> (width, N, words): word (cell, g) holds slots g·width…"""
        planes = per_cell_slot.reshape(groups, width, -1)[:, :, visited]
        return jnp.moveaxis(planes, 0, -1).reshape(width, n, words_per_particle)

    candidates = per_word(members)
    index = jnp.arange(n, dtype=jnp.int32)[:, None]
    in_own_cell = (jnp.arange(words_per_particle) < groups)[None, :]
    safe_members = jnp.minimum(members, n - 1)
    distance_sq = jnp.zeros(candidates.shape, positions.dtype)
    for axis in range(3):
        coordinate = positions[:, axis]
        separation = per_word(coordinate[safe_members]) - coordinate[None, :, None]
        if n_cells[axis] >= 3:
            length = jnp.asarray(box.lengths[axis], positions.dtype)
            own_image = jnp.zeros((n, 1), positions.dtype)
            image = jnp.concatenate([own_image, images[axis][cell_ids].astype(positions.dtype)], 1)
            image = jnp.repeat(image, groups, axis=1) if groups > 1 else image
            separation = separation + (image * length)[None]
        else:
            separation = box.minimum_image(separation, axis)
        distance_sq = distance_sq + separation * separation
    within = (candidates < n) & (distance_sq < list_cutoff**2)
    within = within & (~in_own_cell[None] | (candidates > index[None]))
    accepted = jnp.zeros((n, words_per_particle), jnp.uint32)
    for bit in range(width):
        accepted = accepted | (within[bit].astype(jnp.uint32) << bit)
    return candidates, accepted, max_occupancy


def _compact(candidates, accepted, pair_capacity: int):
    """Flatten the accepted candidates into pair arrays of fixed length.

    Pair slot p is located by three branch-free binary searches: its particle (over
    the cumulative pair counts of the particles), its word (over the cumulative
    counts of that particle's words) and its bit (over popcounts of bit prefixes).

    Returns:
        i, j: (pair_capacity,) int32, padded with N.
        total: int32 number of accepted pairs (may exceed the capacity).
    """
    width, n, words = candidates.shape
    per_word = jax.lax.population_count(accepted).astype(jnp.int32)
    word_inclusive = jnp.cumsum(per_word, axis=1, dtype=jnp.int32)
    per_row = word_inclusive[:, -1]
    row_inclusive = jnp.cumsum(per_row, dtype=jnp.int32)
    total = row_inclusive[-1]
    slots = jnp.arange(pair_capacity, dtype=jnp.int32)
    row = jnp.minimum(_lower_bound(lambda k: row_inclusive[k], n, slots + 1), n - 1)
    rank = slots - (row_inclusive[row] - per_row[row])
    flat_inclusive = word_inclusive.reshape(-1)
    word = _lower_bound(lambda k: flat_inclusive[row * words + k], words, rank + 1)
    word = jnp.minimum(word, words - 1)
    flat = row * words + word
    rank = rank - (flat_inclusive[flat] - per_word.reshape(-1)[flat])
    bits = accepted.reshape(-1)[flat]

    def set_bits_up_to(k):
        prefix = (jnp.uint32(2) << k.astype(jnp.uint32)) - jnp.uint32(1)
        return jax.lax.population_count(bits & prefix).astype(jnp.int32)

    bit = jnp.minimum(_lower_bound(set_bits_up_to, width, rank + 1), width - 1)
    valid = slots < total
    i = jnp.where(valid, row, n)
    j = jnp.where(valid, candidates.reshape(-1)[(bit * n + row) * words + word], n)
    return i, j, total


def cell_list_search(box: PeriodicBox, n_particles: int, cutoff: float, skin: float):
    """jaxdpd's cell-list half neighbour list (see the module docstring).

    Args:
        box: periodic box; requires L > 2 (cutoff + skin) along every axis.
        n_particles: N.
        cutoff: interaction cut-off r_c.
        skin: Verlet skin ≥ 0.
    Returns:
        NeighborSearch with half = True.
    """
    list_cutoff = cutoff + skin
    n_cells = cell_grid(box, list_cutoff)
    cell_size = tuple(length / n for length, n in zip(box.lengths, n_cells, strict=True))
    tables = tuple(jnp.asarray(t) for t in forward_neighbor_cells(n_cells))

    def mask(positions, cell_capacity):
        return _candidates(box, positions, cell_size, n_cells, tables, cell_capacity, list_cutoff)

    def build(positions, cell_capacity: int, pair_capacity: int) -> PairList:
        candidates, accepted, max_occupancy = mask(positions, cell_capacity)
        i, j, total = _compact(candidates, accepted, pair_capacity)
        return PairList(
            i=i,
            j=j,
            reference_positions=positions,
            needed_pairs=total,
            needed_cell_occupancy=max_occupancy,
            overflow=(total > pair_capacity) | (max_occupancy > cell_capacity),
            rebuilds=jnp.asarray(0, jnp.int32),
            cell_capacity=cell_capacity,
        )

    @jax.jit
    def fullest_cell(positions):
        """Occupancy of the fullest cell (sizes the cell buffers)."""
        ids = _cell_ids(positions, cell_size, n_cells)
        return jnp.max(jnp.zeros(math.prod(n_cells), jnp.int32).at[ids].add(1))

    build_jit = jax.jit(build, static_argnums=(1, 2))

    def allocate(positions, capacity_multiplier: float = 1.25, minimum=None) -> PairList:
        """Size the buffers for `positions` (outside jit), then build the list.

        The pair buffer starts from the ideal-gas estimate ½N(N−1)·(4π/3)r_list³/V
        and is re-sized once if the configuration holds more pairs.

        Args:
            positions: (N, 3) wrapped positions.
            capacity_multiplier: head-room factor (≥ 1) on the counts found.
            minimum: optional (pairs, cell occupancy) the buffers must at least hold,
                e.g. the needs recorded when a chunk overflowed.
        """
        min_pairs, min_occupancy = minimum or (0, 0)
        occupancy = max(int(fullest_cell(positions)), int(min_occupancy))
        cell_capacity = occupancy + max(3, math.ceil(0.2 * occupancy))
        ideal = 0.5 * n_particles * (n_particles - 1) * 4 / 3 * math.pi * list_cutoff**3
        pairs = max(ideal / box.volume, int(min_pairs))
        pair_list = build_jit(
            positions, cell_capacity, max(16, math.ceil(pairs * capacity_multiplier))
        )
        if int(pair_list.needed_pairs) > pair_list.capacity:
            needed = math.ceil(int(pair_list.needed_pairs) * capacity_multiplier)
            pair_list = build_jit(positions, cell_capacity, needed)
        return pair_list

    def update(positions, pair_list: PairList) -> PairList:
        def rebuild(old):
            new = build(positions, old.cell_capacity, old.capacity)
            return new.set(
                needed_pairs=jnp.maximum(new.needed_pairs, old.needed_pairs),
                needed_cell_occupancy=jnp.maximum(
                    new.needed_cell_occupancy, old.needed_cell_occupancy
                ),
                overflow=new.overflow | old.overflow,
                rebuilds=old.rebuilds + 1,
            )

        stale = needs_rebuild(box, positions, pair_list.reference_positions, skin)
        return jax.lax.cond(stale, rebuild, lambda old: old, pair_list)

    return NeighborSearch(allocate=allocate, update=update, half=True, cutoff=cutoff, skin=skin)
