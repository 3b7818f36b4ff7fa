"""Neighbour search: lists of particle pairs closer than a cut-off plus a skin.

Two backends produce the same `PairList`:
- `cell_list`: jaxdpd's own cell-list half list, rebuilt when any particle has moved
  more than half the skin.  Fast on CPU (see benchmarks/dpd_throughput.py).
- `jax_md`: `jax_md.partition.neighbor_list` in its dense, sparse or ordered-sparse
  format, adapted to the same pair arrays.
- `all_pairs`: every pair i < j, fixed (small systems such as a single chain).

Pair arrays hold particle indices; unused slots hold N (one past the last particle).
A half list holds each pair once; a full list holds (i, j) and (j, i).
"""

from jaxdpd.geometry.neighbors.pair_list import NeighborSearch, PairList, neighbor_search

__all__ = ["NeighborSearch", "PairList", "neighbor_search"]
