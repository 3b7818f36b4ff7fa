"""jaxdpd's cell list as a jax-md neighbour list (`jax_md.partition.NeighborListFns`).

The list is jaxdpd's cell-list half list (jaxdpd.geometry.neighbors.cell_list), read
out in jax-md's formats: OrderedSparse (2, P) with idx[0] < idx[1] as jax-md builds
it, Sparse (2, 2P) with each pair both ways, Dense (N, K).  Empty slots hold N.  It
bins the box's frame coordinates, so it is valid in sheared and Kraynik–Reinelt boxes
(the box state is passed as `box=` to `allocate` and `update`, as to the space of
jaxdpd.interop.jax_md.space), and it rebuilds when twice the largest displacement
plus the drift of the periodic images since the last build exceeds `dr_threshold`
(jax-md's rule, plus the images' drift that a deforming box adds).

Buffer overflow sets jax-md's error bits (`did_buffer_overflow`): pairs beyond the
capacity (or a Dense row beyond K) set NEIGHBOR_LIST_OVERFLOW, a cell fuller than its
slots CELL_LIST_OVERFLOW; both are sticky, and the caller reallocates with
`allocate`, as with jax-md's own lists.  `allocate` also takes a batch of
configurations (B, N, 3) and returns one list shape that holds every replica, to be
updated under `jax.vmap` (the question of jax-md issue 192).
"""

import functools
import math

import jax
import jax.numpy as jnp
import numpy as np
from jax_md import dataclasses as jmd_dataclasses
from jax_md import partition

from jaxdpd.geometry.neighbors.cell_list import cell_list_search
from jaxdpd.geometry.neighbors.pair_list import PairList
from jaxdpd.interop.jax_md.space import require_state

FORMATS = (partition.Dense, partition.Sparse, partition.OrderedSparse)
PEC = partition.PartitionErrorCode


@jmd_dataclasses.dataclass
class CellNeighborList(partition.NeighborList):
    """jax-md's `NeighborList` with the jaxdpd `PairList` it is read from.

    Attributes:
        pair_list: the cell list's state (pairs, reference positions and box state,
            capacities, what the last builds needed); jaxdpd's pair kernels
            (jaxdpd.forces.pair_sums.pair_geometry) read its (i, j) directly.
    """

    pair_list: PairList


def _ordered(pair_list):
    """(2, P): each pair once, lower index first (jax-md's OrderedSparse)."""
    i, j = pair_list.i, pair_list.j
    return jnp.stack([jnp.minimum(i, j), jnp.maximum(i, j)])


def _sparse(pair_list):
    """(2, 2P): each pair both ways (jax-md's Sparse)."""
    ordered = _ordered(pair_list)
    return jnp.concatenate([ordered, ordered[::-1]], axis=1)


def _row_counts(pair_list, n):
    """(N,) partners of each particle.  Empty slots (index N) fall outside the rows and
    are dropped, rather than all counted at one address, which a GPU serialises."""
    senders = jnp.concatenate([pair_list.i, pair_list.j])
    return jax.ops.segment_sum(jnp.ones(senders.shape, jnp.int32), senders, n)


def _dense(pair_list, n, width):
    """(N, K) partners of each particle (jax-md's Dense), and whether a row had more
    than K partners."""
    senders = jnp.concatenate([pair_list.i, pair_list.j])
    receivers = jnp.concatenate([pair_list.j, pair_list.i])
    order = jnp.argsort(senders, stable=True)
    senders, receivers = senders[order], receivers[order]
    counts = _row_counts(pair_list, n)
    starts = jnp.cumsum(counts) - counts
    # Empty slots (sender N) read a clamped start; their row N is dropped below.
    rank = jnp.arange(senders.shape[0], dtype=jnp.int32) - starts[senders]
    idx = jnp.full((n, width), n, jnp.int32)
    idx = idx.at[senders, rank].set(receivers.astype(jnp.int32), mode="drop")
    return idx, jnp.max(counts) > width


def _error(pair_list, row_overflow):
    """jax-md's error code from the cell list's needs."""
    error = partition.PartitionError(jnp.zeros((), jnp.uint8))
    pairs = (pair_list.needed_pairs > pair_list.capacity) | row_overflow
    error = error.update(PEC.NEIGHBOR_LIST_OVERFLOW, pairs)
    cells = pair_list.needed_cell_occupancy > pair_list.cell_capacity
    return error.update(PEC.CELL_LIST_OVERFLOW, cells)


def _padded(pair_list, capacity: int, cell_capacity: int):
    """The same pairs in `capacity` slots, rebuilt later with `cell_capacity` slots per
    cell (the cell list's pairs do not depend on its buffer sizes)."""
    fill = pair_list.reference_positions.shape[0]
    extra = capacity - pair_list.capacity
    return pair_list.set(
        i=jnp.pad(pair_list.i, (0, extra), constant_values=fill),
        j=jnp.pad(pair_list.j, (0, extra), constant_values=fill),
        cell_capacity=cell_capacity,
    )


@functools.cache
def _search(box, n: int, r_cutoff: float, dr_threshold: float):
    """One cell list (and its compiled builds) per box, N, cut-off and skin, shared by
    every list made for them, whatever the format."""
    return cell_list_search(box, n, r_cutoff, dr_threshold)


def neighbor_list(
    box,
    r_cutoff: float,
    dr_threshold: float = 0.0,
    capacity_multiplier: float = 1.25,
    format: partition.NeighborListFormat = partition.OrderedSparse,  # noqa: A002 (jax-md's name)
) -> partition.NeighborListFns:
    """jax-md `NeighborListFns` backed by jaxdpd's cell list (see the module docstring).

        allocate(position, extra_capacity=0, box=state) -> CellNeighborList  (not jit)
        update(position, neighbors, box=state) -> CellNeighborList           (jit, vmap)

    Args:
        box: a jaxdpd box (periodic, Lees–Edwards or Kraynik–Reinelt).
        r_cutoff: interaction cut-off (length units of the box).
        dr_threshold: Verlet skin; pairs within r_cutoff + dr_threshold are listed.
        capacity_multiplier: head-room (≥ 1) on the pairs (and Dense row) found.
        format: partition.OrderedSparse, Sparse or Dense.
    Raises:
        ValueError: an unknown format, or r_cutoff + dr_threshold at or beyond half
            the thinnest cell height of the box (the minimum image would be
            ambiguous: jax-md issue 200).
    """
    static_box = box  # `box=` below is the per-call state, as in jax-md
    if format not in FORMATS:
        raise ValueError(f"format = {format!r}; valid: {[f.name for f in FORMATS]}")
    list_cutoff = r_cutoff + dr_threshold
    thinnest = min(box.cell_heights)
    if not 0 < list_cutoff < thinnest / 2:
        raise ValueError(
            f"r_cutoff + dr_threshold = {list_cutoff}: must be positive and below half the "
            f"thinnest cell height {thinnest:.6g} of this {box.name!r} box (box.cell_heights)"
        )

    def search(n: int):
        return _search(box, n, r_cutoff, dr_threshold)

    def read_out(pair_list, width: int):
        n = pair_list.reference_positions.shape[0]
        if format is partition.Dense:
            return _dense(pair_list, n, width)
        indices = _ordered(pair_list) if format is partition.OrderedSparse else _sparse(pair_list)
        return indices, jnp.asarray(False)

    def wrap(pair_list, width: int, idx, row_overflow, previous=None):
        error = _error(pair_list, row_overflow)
        if previous is not None:
            error = partition.PartitionError(error.code | previous.code)
        return CellNeighborList(
            idx,
            pair_list.reference_positions,
            error,
            pair_list.cell_capacity,
            width if format is partition.Dense else idx.shape[1],
            format,
            None,
            None,
            update_fn,
            pair_list,
        )

    def allocate_one(position, extra_capacity, box_state):
        n = position.shape[0]
        pair_list = search(n).allocate(position, capacity_multiplier, None, box_state)
        pair_list = _padded(
            pair_list, pair_list.capacity + n * extra_capacity, pair_list.cell_capacity
        )
        widest = int(np.max(np.asarray(_row_counts(pair_list, n))))
        width = min(n - 1, math.ceil(widest * capacity_multiplier) + extra_capacity)
        return pair_list, max(width, 1)

    def allocate_fn(position, extra_capacity: int = 0, box=None, **unused_kwargs):
        """A list sized for `position` (N, 3), or one shape for a batch (B, N, 3) with
        a batched box state."""
        require_state(static_box, box, "allocate(position, box=)")
        if jnp.ndim(position) == 2:
            pair_list, width = allocate_one(position, extra_capacity, box)
            return wrap(pair_list, width, *read_out(pair_list, width))
        replicas = [
            allocate_one(position[b], extra_capacity, jax.tree.map(lambda leaf, b=b: leaf[b], box))
            for b in range(position.shape[0])
        ]
        capacity = max(pair_list.capacity for pair_list, _ in replicas)
        cell_capacity = max(pair_list.cell_capacity for pair_list, _ in replicas)
        width = max(w for _, w in replicas)
        lists = []
        for pair_list, _ in replicas:
            pair_list = _padded(pair_list, capacity, cell_capacity)
            lists.append(wrap(pair_list, width, *read_out(pair_list, width)))
        return jax.tree.map(lambda *leaves: jnp.stack(leaves), *lists)

    def update_fn(position, neighbors, box=None, **unused_kwargs):
        """The list for `position`, rebuilt if a pair may have come within r_cutoff
        unlisted; keeps the shapes (jittable, vmappable)."""
        require_state(static_box, box, "update(position, neighbors, box=)")
        old = neighbors.pair_list
        pair_list = search(position.shape[0]).update(position, old, box)
        width = neighbors.max_occupancy
        idx, row_overflow = jax.lax.cond(
            pair_list.rebuilds != old.rebuilds,
            lambda: read_out(pair_list, width),
            lambda: (neighbors.idx, jnp.asarray(False)),
        )
        return wrap(pair_list, width, idx, row_overflow, neighbors.error)

    return partition.NeighborListFns(allocate_fn, update_fn)
