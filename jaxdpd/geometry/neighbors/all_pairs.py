"""Every pair i < j, listed once and never rebuilt: the neighbour "search" of small
systems (a single chain of tens of beads), where a cell grid spanning the whole box
costs far more than the N(N−1)/2 distance tests, and whose fixed list keeps a vmapped
ensemble free of per-replica rebuild branches."""

import jax.numpy as jnp
import numpy as np

from jaxdpd.geometry.neighbors.pair_list import NeighborSearch, PairList


def all_pairs_search(n_particles: int, cutoff: float) -> NeighborSearch:
    """A NeighborSearch listing all N(N−1)/2 pairs (half list).

    Args:
        n_particles: N.
        cutoff: interaction cut-off r_c (pairs beyond it are masked by the pair
            geometry, as for the other backends).
    Returns:
        NeighborSearch with half = True and skin 0.
    """
    i, j = np.triu_indices(n_particles, 1)
    count = jnp.asarray(len(i), jnp.int32)

    def allocate(
        positions, capacity_multiplier: float = 1.25, minimum=None, box_state=None
    ) -> PairList:
        """The fixed list (capacity_multiplier and minimum are irrelevant: it never
        overflows; every pair is listed whatever the box state)."""
        zero = jnp.asarray(0, jnp.int32)
        return PairList(
            i=jnp.asarray(i, jnp.int32),
            j=jnp.asarray(j, jnp.int32),
            reference_positions=positions,
            reference_box_state=box_state,
            needed_pairs=count,
            needed_cell_occupancy=zero,
            overflow=jnp.asarray(False),
            rebuilds=zero,
        )

    def update(positions, pair_list: PairList, box_state=None) -> PairList:
        return pair_list

    return NeighborSearch(allocate=allocate, update=update, half=True, cutoff=cutoff, skin=0.0)
