"""The `PairList` state and the factory that picks a backend."""

from collections.abc import Callable
from dataclasses import dataclass

import jax.numpy as jnp
from jax_md import dataclasses as jmd_dataclasses

from jaxdpd.boxes import PeriodicBox


@jmd_dataclasses.dataclass
class PairList:
    """Candidate pairs within cutoff + skin, with what is needed to refresh them.

    Attributes:
        i, j: (P,) int32 particle indices; empty slots hold N.
        reference_positions: (N, 3) positions at the last rebuild (skin test).
        needed_pairs: int32, pairs found at the last rebuild (may exceed P).
        needed_cell_occupancy: int32, fullest cell at the last rebuild.
        overflow: bool, True when the last rebuild did not fit the capacities.
        rebuilds: int32, number of rebuilds so far (diagnostic).
        backend: backend-specific state (the jax-md NeighborList), or None.
        cell_capacity: static, particles per cell the cell list can hold.
    """

    i: jnp.ndarray
    j: jnp.ndarray
    reference_positions: jnp.ndarray
    needed_pairs: jnp.ndarray
    needed_cell_occupancy: jnp.ndarray
    overflow: jnp.ndarray
    rebuilds: jnp.ndarray
    backend: object = None
    cell_capacity: int = jmd_dataclasses.static_field(default=0)

    @property
    def capacity(self) -> int:
        """Number of pair slots P."""
        return self.i.shape[0]


@dataclass(frozen=True)
class NeighborSearch:
    """A neighbour-search backend.

    Attributes:
        allocate: `allocate(positions, capacity_multiplier) -> PairList`, called
            outside jit: sizes the buffers from the configuration it is given.
        update: `update(positions, pair_list) -> PairList`, jittable: rebuilds when
            any particle moved more than skin/2 since the last rebuild.
        half: True when each pair is listed once.
        cutoff: interaction cut-off r_c.
        skin: Verlet skin added to the cut-off.
    """

    allocate: Callable
    update: Callable
    half: bool
    cutoff: float
    skin: float


def needs_rebuild(box: PeriodicBox, positions, reference_positions, skin: float):
    """True when some particle moved more than skin/2 since the reference.

    Args:
        box: the periodic box (displacements are minimum-image).
        positions, reference_positions: (N, 3) arrays.
        skin: Verlet skin; with skin = 0 the list is rebuilt every step.
    """
    if skin == 0:
        return jnp.asarray(True)
    moved = box.minimum_image_vectors(positions - reference_positions)
    max_sq = jnp.max(jnp.sum(moved * moved, axis=1))
    return max_sq > (0.5 * skin) ** 2


def neighbor_search(
    box: PeriodicBox,
    n_particles: int,
    cutoff: float,
    skin: float,
    method: str = "cell_list",
    jax_md_format: str = "ordered_sparse",
) -> NeighborSearch:
    """Build a neighbour-search backend.

    Args:
        box: the periodic box.
        n_particles: N.
        cutoff: interaction cut-off r_c.
        skin: Verlet skin (≥ 0); pairs within cutoff + skin are listed.
        method: "cell_list" (jaxdpd's own), "jax_md", or "all_pairs" (every pair,
            for small systems).
        jax_md_format: "dense", "sparse" or "ordered_sparse" (method "jax_md" only).
    """
    if method == "cell_list":
        from jaxdpd.neighbors.cell_list import cell_list_search

        return cell_list_search(box, n_particles, cutoff, skin)
    if method == "jax_md":
        from jaxdpd.neighbors.jax_md_lists import jax_md_search

        return jax_md_search(box, n_particles, cutoff, skin, jax_md_format)
    if method == "all_pairs":
        from jaxdpd.neighbors.all_pairs import all_pairs_search

        return all_pairs_search(n_particles, cutoff)
    raise ValueError(f"neighbors.method = {method!r}; valid: 'cell_list', 'jax_md', 'all_pairs'")
