"""Adapter: jax-md's `partition.neighbor_list` as a jaxdpd `NeighborSearch`.

Dense lists (N, K) and sparse lists (2, P) are full lists (each pair twice);
ordered-sparse lists are half lists.  Capacities and the rebuild test (half the
skin, jax-md's `dr_threshold`) are jax-md's own; overflow is its sticky
`did_buffer_overflow` flag.
"""

import functools

import jax.numpy as jnp
from jax_md import partition, space

from jaxdpd.geometry.boxes import PeriodicBox
from jaxdpd.geometry.neighbors.pair_list import NeighborSearch, PairList

FORMATS = {
    "dense": partition.Dense,
    "sparse": partition.Sparse,
    "ordered_sparse": partition.OrderedSparse,
}


def _pair_arrays(neighbors, n_particles: int):
    """(i, j) arrays of a jax-md NeighborList in any format."""
    if neighbors.format == partition.Dense:
        width = neighbors.idx.shape[1]
        i = jnp.repeat(jnp.arange(n_particles, dtype=jnp.int32), width)
        j = neighbors.idx.reshape(-1).astype(jnp.int32)
        return jnp.where(j < n_particles, i, n_particles), j
    return neighbors.idx[0].astype(jnp.int32), neighbors.idx[1].astype(jnp.int32)


def jax_md_search(box: PeriodicBox, n_particles: int, cutoff: float, skin: float, fmt: str):
    """A NeighborSearch backed by `jax_md.partition.neighbor_list`.

    Args:
        box: periodic box.
        n_particles: N.
        cutoff: interaction cut-off r_c.
        skin: Verlet skin (jax-md's dr_threshold).
        fmt: "dense", "sparse" or "ordered_sparse".
    """
    if fmt not in FORMATS:
        raise ValueError(f"neighbors.format = {fmt!r}; valid: {sorted(FORMATS)}")
    sides = jnp.asarray(box.lengths)

    # One list function per (dtype, multiplier): jax-md's update function is a
    # static field of its NeighborList, so a fresh closure per allocation would
    # recompile every chunk that carries the list.
    @functools.lru_cache(maxsize=8)
    def make_list_fn(dtype, capacity_multiplier):
        displacement, _ = space.periodic(sides.astype(dtype))
        return partition.neighbor_list(
            displacement,
            sides.astype(dtype),
            cutoff,
            dr_threshold=skin,
            capacity_multiplier=capacity_multiplier,
            format=FORMATS[fmt],
        )

    def wrap(neighbors, rebuilds):
        i, j = _pair_arrays(neighbors, n_particles)
        return PairList(
            i=i,
            j=j,
            reference_positions=neighbors.reference_position,
            reference_box_state=None,
            needed_pairs=jnp.asarray(0, jnp.int32),
            needed_cell_occupancy=jnp.asarray(0, jnp.int32),
            overflow=jnp.asarray(neighbors.did_buffer_overflow),
            rebuilds=rebuilds,
            backend=neighbors,
        )

    def allocate(
        positions, capacity_multiplier: float = 1.25, minimum=None, box_state=None
    ) -> PairList:
        """Allocate with jax-md (outside jit); `minimum` is ignored: jax-md resizes
        from the configuration, and a larger multiplier is used after an overflow.
        Periodic boxes at rest only (`box_state` must be None)."""
        multiplier = capacity_multiplier * (1.5 if minimum else 1.0)
        neighbors = make_list_fn(positions.dtype, multiplier).allocate(positions)
        return wrap(neighbors, jnp.asarray(0, jnp.int32))

    def update(positions, pair_list: PairList, box_state=None) -> PairList:
        neighbors = pair_list.backend.update(positions)
        rebuilt = jnp.any(neighbors.reference_position != pair_list.reference_positions)
        return wrap(neighbors, pair_list.rebuilds + rebuilt.astype(jnp.int32))

    half = fmt == "ordered_sparse"
    return NeighborSearch(allocate=allocate, update=update, half=half, cutoff=cutoff, skin=skin)
