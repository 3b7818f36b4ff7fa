"""The neighbour buffers of a built scene: allocating, refitting and comparing them.

A scene has up to two neighbour lists in its state, the particle pair list (for pair
terms and pair thermostats, over the particles that feel forces) and the spring-pair
list (for spring–spring repulsion and the "spring_pairs" observable).  Their sizes
are static shapes of the compiled step; this is the host-side bookkeeping that sizes
them from positions and grows or shrinks them after a run reports what it needed.
"""

from dataclasses import dataclass

import jax.numpy as jnp
import numpy as np

from jaxdpd.geometry.neighbors import NeighborSearch, PairList
from jaxdpd.geometry.neighbors.spring_pair_list import (
    SpringPairSearch,
    spring_pair_needs,
    spring_pair_shapes,
)


@dataclass(frozen=True)
class NeighborBuffers:
    """Sizing of a scene's neighbour lists.

    Attributes:
        search: the particle pair list's backend, or None (no pair term or thermostat).
        spring_search: the spring-pair list's builder, or None.
        force_range: (first, stop) of the particles the pair list covers.
        capacity_multiplier: headroom of a freshly sized pair list (neighbors.*).
    """

    search: NeighborSearch | None
    spring_search: SpringPairSearch | None
    force_range: tuple[int, int]
    capacity_multiplier: float

    def pair_list(self, positions, box_state, minimum=None):
        """A pair list sized for `positions` (and at least `minimum` (pairs, cell
        occupancy)); a one-slot empty list when the scene has no pair search."""
        if self.search is None:
            return _empty_pair_list(positions)
        first, stop = self.force_range
        rows = positions[first:stop]
        return self.search.allocate(rows, self.capacity_multiplier, minimum, box_state)

    def spring_pairs(self, positions, box_state, minimum=None):
        """A spring-pair list sized for `positions`, or None without one."""
        if self.spring_search is None:
            return None
        return self.spring_search.allocate(positions, box_state, minimum)

    def reallocate(self, state, minimum=None):
        """`state` with buffers re-sized from its positions to hold at least `minimum`
        (a tuple as `needs` gives it; for a batch, arrays over replicas, of which the
        largest counts), or fitted to the state alone when None."""
        if minimum is not None:
            minimum = tuple(np.max(v) for v in minimum)
        particles = None if minimum is None else minimum[:2]
        state = state.set(pair_list=self.pair_list(state.positions, state.box_state, particles))
        if self.spring_search is None:
            return state
        # Without recorded needs, keep at least the longest spring seen so far.
        springs = minimum[2:] if minimum is not None and len(minimum) > 2 else None
        springs = springs or (0, 0, np.asarray(state.spring_pairs.longest))
        return state.set(spring_pairs=self.spring_pairs(state.positions, state.box_state, springs))

    def needs(self, state) -> tuple:
        """What every buffer needed during the last chunk, as NumPy values."""
        pair_list = state.pair_list
        needs = (np.asarray(pair_list.needed_pairs), np.asarray(pair_list.needed_cell_occupancy))
        if self.spring_search is not None:
            needs += spring_pair_needs(state.spring_pairs)
        return needs

    def fitted_shapes(self, state) -> tuple:
        """The shapes `reallocate(state, None)` would give the particle pair list
        (the pairs it needed since it was sized kept as a floor), found without
        building anything; the current shapes where the backend cannot tell."""
        shapes = self.shapes(state)
        if self.search is None or self.search.fit is None:
            return shapes
        first, stop = self.force_range
        pairs = (np.asarray(state.pair_list.needed_pairs), 0)
        fitted = self.search.fit(
            state.positions[first:stop], self.capacity_multiplier, pairs, state.box_state
        )
        return fitted + shapes[2:]

    def shapes(self, state) -> tuple:
        """The static buffer sizes that replicas must share to be stacked."""
        shapes = (state.pair_list.capacity, state.pair_list.cell_capacity)
        if self.spring_search is not None:
            shapes += spring_pair_shapes(state.spring_pairs)
        return shapes


def _empty_pair_list(positions):
    """A one-slot, never-refreshed pair list for scenes without pair terms."""
    n = positions.shape[0]
    empty = jnp.full((1,), n, jnp.int32)
    zero = jnp.asarray(0, jnp.int32)
    return PairList(empty, empty, positions, None, zero, zero, jnp.asarray(False), zero)
