"""The `PairList` state and the factory that picks a backend."""

from collections.abc import Callable
from dataclasses import dataclass

import jax.numpy as jnp

from jaxdpd import pytree


@pytree.dataclass
class PairList:
    """Candidate pairs within cutoff + skin, with what is needed to refresh them.

    Attributes:
        i, j: (P,) int32 particle indices; empty slots hold N.
        reference_positions: (N, 3) positions at the last rebuild (skin test).
        reference_box_state: the box state at the last rebuild (None at rest).
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
    reference_box_state: object
    needed_pairs: jnp.ndarray
    needed_cell_occupancy: jnp.ndarray
    overflow: jnp.ndarray
    rebuilds: jnp.ndarray
    backend: object = None
    cell_capacity: int = pytree.static_field(default=0)

    @property
    def capacity(self) -> int:
        """Number of pair slots P."""
        return self.i.shape[0]


@dataclass(frozen=True)
class NeighborSearch:
    """A neighbour-search backend.

    Attributes:
        allocate: `allocate(positions, capacity_multiplier, minimum, box_state)
            -> PairList`, called outside jit: sizes the buffers from the
            configuration it is given.
        update: `update(positions, pair_list, box_state) -> PairList`, jittable:
            rebuilds when a pair may have come within the cut-off unlisted (see
            `needs_rebuild`).
        half: True when each pair is listed once.
        cutoff: interaction cut-off r_c.
        skin: Verlet skin added to the cut-off.
        fit: `fit(positions, capacity_multiplier, minimum, box_state) -> (pair
            capacity, cell capacity)`, host side: the sizes `allocate` would start
            from, found without building a list; None where a backend cannot tell
            (its buffers are then never shrunk by the driver).
    """

    allocate: Callable
    update: Callable
    half: bool
    cutoff: float
    skin: float
    fit: Callable | None = None


def needs_rebuild(box, positions, pair_list, box_state, skin: float):
    """True when a pair may have come within the cut-off unlisted: when twice the
    largest displacement since the last rebuild, plus how far the periodic images
    have moved against the primary box (`box.image_drift`, the offset change of a
    Lees–Edwards box), exceeds the skin.

    Args:
        box: the static box (displacements are minimum-image in its current state).
        positions: (N, 3) wrapped positions.
        pair_list: the list, with its reference positions and box state.
        box_state: the current box state (None at rest).
        skin: Verlet skin; with skin = 0 the list is rebuilt every step.
    """
    if skin == 0:
        return jnp.asarray(True)
    moved = box.bind(box_state).minimum_image_vectors(positions - pair_list.reference_positions)
    largest = jnp.sqrt(jnp.max(jnp.sum(moved * moved, axis=1)))
    drift = box.image_drift(box_state, pair_list.reference_box_state)
    return 2 * largest + drift > skin


def neighbor_search(
    box,
    n_particles: int,
    cutoff: float,
    skin: float,
    method: str = "cell_list",
    jax_md_format: str = "ordered_sparse",
) -> NeighborSearch:
    """Build a neighbour-search backend.

    Args:
        box: the static box (periodic, or flowing for the cell list).
        n_particles: N.
        cutoff: interaction cut-off r_c.
        skin: Verlet skin (≥ 0); pairs within cutoff + skin are listed.
        method: "cell_list" (jaxdpd's own), "jax_md", or "all_pairs" (every pair,
            for small systems).
        jax_md_format: "dense", "sparse" or "ordered_sparse" (method "jax_md" only).
    """
    if method == "cell_list":
        from jaxdpd.geometry.neighbors.cell_list import cell_list_search

        return cell_list_search(box, n_particles, cutoff, skin)
    if method == "jax_md":
        from jaxdpd.geometry.neighbors.jax_md_lists import jax_md_search

        return jax_md_search(box, n_particles, cutoff, skin, jax_md_format)
    if method == "all_pairs":
        from jaxdpd.geometry.neighbors.all_pairs import all_pairs_search

        return all_pairs_search(n_particles, cutoff)
    raise ValueError(f"neighbors.method = {method!r}; valid: 'cell_list', 'jax_md', 'all_pairs'")
