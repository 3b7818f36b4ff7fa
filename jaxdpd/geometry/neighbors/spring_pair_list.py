"""Spring-pair list: candidate pairs of springs for the segment–segment terms.

Two springs of lengths ℓ1, ℓ2 whose midpoints lie d apart come no closer than
d − (ℓ1 + ℓ2)/2 (thesis fig. 5-3).  So, if no spring is longer than the *listed
length* ℓ_L, every pair that can come within the reach D_c (the repulsion range, or
the largest distance the spring-pair histogram asks for) has midpoints closer than
ℓ_L + D_c.  The list is jaxdpd's cell list (jaxdpd.geometry.neighbors.cell_list) over the
wrapped spring midpoints, with cut-off ℓ_L + D_c and its own skin, refreshed when
a midpoint has moved half the skin (the usual Verlet criterion: a pair unlisted at
d ≥ ℓ_L + D_c + skin cannot get closer than ℓ_L + D_c before then).  Each step then
screens the listed pairs by the centre distance of fig. 5-3 with the springs'
actual lengths (jaxdpd.forces.spring_repulsion.spring_pair_geometry), as the thesis does (§5.2.2).

Overflow works as for the particle list: the list records the pairs and cell
occupancy it needed and the longest spring it has seen; a spring longer than ℓ_L, a
full pair buffer or a full cell sets the state's NEIGHBOR_OVERFLOW flag, and the
driver reallocates (a larger ℓ_L changes the cell grid, so the step recompiles) and
reruns the chunk.  ℓ_L starts at the length a free spring exceeds with probability
10⁻⁶ at k_BT, or 1.1 × the longest spring present if longer; it grows, never
shrinks.  A spring pair must not interact through two periodic images, so
ℓ_L + D_c + skin stays below half the box's thinnest height; springs too long for
that stop the run with a message.
"""

import functools
import math
from dataclasses import dataclass

import jax
import jax.numpy as jnp
import numpy as np

from jaxdpd import pytree
from jaxdpd.engine import errors
from jaxdpd.forces.spring_repulsion import SpringTable, spring_pair_geometry, spring_vectors
from jaxdpd.geometry.neighbors.cell_list import cell_list_search
from jaxdpd.geometry.neighbors.pair_list import PairList

# Per-spring probability that a free spring is longer than the initial listed length.
FREE_SPRING_TAIL = 1e-6
# Head-room on the longest spring seen when the listed length is (re)chosen.
LENGTH_HEADROOM = 1.1
# Listed lengths are rounded up to multiples of this (units of r_c): fewer distinct
# cell grids, fewer recompilations.
LENGTH_QUANTUM = 1.0 / 16.0


@pytree.dataclass
class SpringPairList:
    """Candidate spring pairs and what is needed to refresh and resize them.

    Attributes:
        pairs: PairList over springs (indices into the SpringTable; empty slots hold
            S): midpoint pairs within listed_length + reach + skin at the last rebuild.
        longest: the longest spring seen since the list was allocated.
        listed_length: static, ℓ_L: the list is complete while no spring is longer.
    """

    pairs: PairList
    longest: jnp.ndarray
    listed_length: float = pytree.static_field(default=0.0)

    @property
    def overflow(self):
        """True when the buffers or the listed length were too small at some step."""
        return self.pairs.overflow | (self.longest > self.listed_length)


def free_spring_length(law, kT: float, tail: float = FREE_SPRING_TAIL) -> float:
    """The length a free spring exceeds with probability `tail` at temperature kT.

    The length of a spring alone has density ∝ Q² exp(−U(Q)/k_BT) (U: the bond law's
    energy); its upper quantile is found on a grid of 20 001 lengths up to the law's
    maximum extension, or to where U rises 80 k_BT above its minimum.

    Args:
        law: jaxdpd.forces.bonds.Bond.
        kT: k_BT.
        tail: the probability of a longer spring.
    Returns:
        The length (units of r_c).
    """

    def energy(lengths):
        with np.errstate(invalid="ignore", divide="ignore"):
            return np.asarray(law.energy(jnp.asarray(lengths**2, jnp.float64)), np.float64)

    top = law.max_extension
    if top is None:
        top = law.placement_length
        while energy(np.asarray([top]))[0] - np.nanmin(energy(np.linspace(0, top, 201))) < 80 * kT:
            top *= 2
    lengths = np.linspace(0.0, top, 20001)[1:-1]
    exponent = -(energy(lengths) - np.nanmin(energy(lengths))) / kT
    weights = lengths**2 * np.exp(np.where(np.isfinite(exponent), exponent, -np.inf))
    survival = 1 - np.cumsum(weights) / np.sum(weights)
    return float(lengths[np.argmax(survival < tail)])


@functools.lru_cache(maxsize=32)
def _midpoint_search(box, n_springs: int, cutoff: float, skin: float):
    """The cell-list search over midpoints for one cut-off (cached: its jitted
    functions are reused by every list of that listed length)."""
    return cell_list_search(box, n_springs, cutoff, skin)


@dataclass(frozen=True)
class SpringPairSearch:
    """Builds, refreshes and measures the spring-pair list of a scene's springs.

    Args:
        box: the static box (periodic or flowing).
        table: the springs (jaxdpd.forces.spring_repulsion.SpringTable).
        reach: D_c, the largest closest-approach distance that matters (units of r_c).
        skin: the list's Verlet skin (≥ 0).
        initial_length: the smallest listed length to allocate (e.g.
            `free_spring_length` of the chains' bond laws).
        capacity_multiplier: head-room on the pair buffer (as for the particle list).
    """

    box: object
    table: SpringTable
    reach: float
    skin: float
    initial_length: float
    capacity_multiplier: float = 1.25

    @property
    def length_limit(self) -> float:
        """The longest listed length the box allows: ℓ_L + D_c + skin < h_min/2."""
        return 0.5 * min(self.box.cell_heights) - self.reach - self.skin

    def _search(self, listed_length: float):
        return _midpoint_search(self.box, self.table.count, listed_length + self.reach, self.skin)

    def listed_length(self, longest: float) -> float:
        """ℓ_L for springs up to `longest` long: head-room, rounded up, within the
        box's limit.

        Raises:
            SimulationError: the springs are too long for the box.
        """
        limit = self.length_limit
        if not longest < limit:
            half_height = 0.5 * min(self.box.cell_heights)
            raise errors.SimulationError(
                f"a spring of length {longest:.4g} is too long for the spring-pair list: "
                "spring pairs are listed by midpoints within ℓ + range + skin, which must "
                f"stay below half the box's thinnest height ({half_height:.4g}), so springs "
                f"may be at most {limit:.4g} long here; enlarge the box, or reduce "
                "neighbors.spring_skin or spring_repulsion.range"
            )
        wanted = max(self.initial_length, LENGTH_HEADROOM * longest)
        quantised = LENGTH_QUANTUM * math.ceil(wanted / LENGTH_QUANTUM)
        # Just below the limit (the cell list needs its cut-off under half a height).
        return min(quantised, limit * (1 - 1e-6))

    def allocate(self, positions, box_state=None, minimum=None) -> SpringPairList:
        """Size the buffers for `positions` (outside jit), then build the list.

        Args:
            positions: (N, 3) wrapped bead positions.
            box_state: the box state of a flowing box (None at rest).
            minimum: optional (pairs, cell occupancy, spring length) the list must at
                least hold, e.g. the needs recorded when a chunk overflowed.
        """
        min_pairs, min_occupancy, min_length = minimum or (0, 0, 0.0)
        springs, midpoints = _spring_vectors(self.box, self.table, positions, box_state)
        lengths = np.linalg.norm(np.asarray(springs), axis=-1)
        longest = max(float(np.max(lengths, initial=0.0)), float(min_length))
        listed_length = self.listed_length(longest)
        pairs = self._search(listed_length).allocate(
            midpoints,
            self.capacity_multiplier,
            (int(min_pairs), int(min_occupancy)),
            box_state,
        )
        return SpringPairList(pairs, jnp.asarray(longest, springs.dtype), listed_length)

    def _measure(self, positions, spring_pairs: SpringPairList, box_state, refresh: bool):
        bound_box = self.box.bind(box_state)
        springs, midpoints = spring_vectors(bound_box, positions, self.table)
        if refresh:
            longest = jnp.sqrt(jnp.max(jnp.sum(springs * springs, axis=-1)))
            search = self._search(spring_pairs.listed_length)
            spring_pairs = spring_pairs.set(
                pairs=search.update(midpoints, spring_pairs.pairs, box_state),
                longest=jnp.maximum(spring_pairs.longest, longest.astype(springs.dtype)),
            )
        geometry = spring_pair_geometry(
            bound_box,
            springs,
            midpoints,
            self.table,
            spring_pairs.pairs.i,
            spring_pairs.pairs.j,
            self.reach,
        )
        return spring_pairs, geometry

    def refresh(self, positions, spring_pairs: SpringPairList, box_state=None):
        """Refresh the list for `positions` (traced) and measure its pairs there.

        Returns:
            (refreshed SpringPairList, jaxdpd.forces.spring_repulsion.SpringPairGeometry).
        """
        return self._measure(positions, spring_pairs, box_state, refresh=True)

    def measure(self, positions, spring_pairs: SpringPairList, box_state=None):
        """Measure the listed pairs at `positions` without refreshing the list (e.g. at
        the previous step's positions); returns SpringPairGeometry."""
        return self._measure(positions, spring_pairs, box_state, refresh=False)[1]


@functools.partial(jax.jit, static_argnums=(0, 1))
def _spring_vectors(box, table, positions, box_state):
    return spring_vectors(box.bind(box_state), positions, table)


def spring_pair_needs(spring_pairs: SpringPairList) -> tuple:
    """(pairs, cell occupancy, longest spring) the list needed (NumPy; arrays for a
    batch of replicas)."""
    pairs = spring_pairs.pairs
    return (
        np.asarray(pairs.needed_pairs),
        np.asarray(pairs.needed_cell_occupancy),
        np.asarray(spring_pairs.longest),
    )


def spring_pair_shapes(spring_pairs: SpringPairList) -> tuple:
    """The static sizes two lists must share to be stacked into one batch."""
    return (
        spring_pairs.pairs.capacity,
        spring_pairs.pairs.cell_capacity,
        spring_pairs.listed_length,
    )
