"""Spring–spring (segment–segment) closest approach and repulsion (thesis §5.2).

Geometry (thesis §5.2.1, after Kumar & Larson, J. Chem. Phys. 114, 6937 (2001)).  A
spring is the segment between beads r_k and r_{k+1}: midpoint P = (r_k + r_{k+1})/2,
spring vector R = r_{k+1} − r_k (minimum image), points P + t R with t ∈ [−½, ½].  The
vector between a point of spring 1 and one of spring 2 is (eq. 5.1)

    D(t1, t2) = P1 + t1 R1 − (P2 + t2 R2),

and |D|² is a convex quadratic in (t1, t2).  Its unconstrained minimum (eq. 5.2) is at
(eqs. 5.3–5.4, with a = R1·R1, e = R2·R2, b = R1·R2, c = R1·d, f = R2·d, d = P1 − P2)

    t1 = (b f − c e)/Δ,   t2 = (a f − b c)/Δ,   Δ = a e − b²,

the closest points of the two infinite lines.  Kumar and Larson clip t outside
[−½, ½] to the ends, which fails for nearly parallel springs (thesis fig. 5-2); the
thesis adds a check of the four end–end distances, still not exact (an end of one
spring may lie closest to the inside of the other).  Here the constrained minimum is
found exactly: a convex function's minimum over the square [−½, ½]² is its
unconstrained minimum when that lies inside (and Δ > 0), and otherwise lies on an
edge, where fixing t1 = ±½ (or t2 = ±½) leaves a 1-D convex quadratic minimised by
clipping its stationary point.  The smallest of these five candidates is the
distance between the segments, for every configuration: crossing, parallel
(Δ = 0: an edge attains the minimum), end to end, or a spring of zero length.

Forces.  A pair of springs at closest distance D = |D| has energy U(D); by Danskin's
theorem its gradient with respect to the beads is that at fixed (t1, t2), so with
F = f(D) D/D (f = −dU/dD ≥ 0, acting on spring 1) the four beads receive

    F_k = (½ − t1) F,  F_{k+1} = (½ + t1) F,  F_l = −(½ − t2) F,  F_{l+1} = −(½ + t2) F:

the force at the points of closest approach shared with lever weights.  They sum to
zero (momentum) and their torque about any origin is D × F = 0 (angular momentum).
The pair's virial Σ_beads r ⊗ F is D ⊗ F.  Exactly parallel springs whose
projections overlap have a line of closest points; the energy is not differentiable
there (a tilt either way moves the closest point to one end), and one of its
minimisers on an edge is taken.

Laws (f: force magnitude along D̂, positive = repulsive; U: energy, zero at and
beyond the range D_c; D is floored at D_min = 0.001 r_c in the force (thesis §5.2.2:
closer springs are "treated as though their separation distance were 0.001 r_c"),
and the energy continues linearly below D_min so that f = −dU/dD everywhere):

    exponential  f = A α e^{−α D},  U = A (e^{−α D} − e^{−α D_c})        (Kumar–Larson,
                 thesis eq. 5.6; A = 100 k_BT, α = 10/r_c)
    linear       f = 3 a (1 − D/D_c),  U = (3/2) a D_c (1 − D/D_c)²         (Pan–Manke,
                 thesis eq. 5.5: 3a times the DPD weight over the range D_c = r_c/3,
                 "a slope nine times greater than that of the conservative force")
"""

import math
from collections.abc import Callable
from dataclasses import dataclass

import jax.numpy as jnp
import numpy as np

from jaxdpd import pytree
from jaxdpd.dyadic import dyadic_square
from jaxdpd.scatter import segment_sum_where

SPRING_REPULSION_LAWS = ("exponential", "linear")


# -- closest approach ------------------------------------------------------------------
@pytree.dataclass
class SegmentApproach:
    """Closest approach of pairs of segments (traced arrays, batch shape (...)).

    Attributes:
        vector: (..., 3) D = P1 + t1 R1 − P2 − t2 R2, from spring 2's closest point to
            spring 1's.
        distance: (...) |D|.
        t1, t2: (...) the segment parameters of the closest points, in [−½, ½].
    """

    vector: jnp.ndarray
    distance: jnp.ndarray
    t1: jnp.ndarray
    t2: jnp.ndarray


def _dot(u, v):
    return jnp.sum(u * v, axis=-1)


def _safe_quotient(numerator, denominator, valid):
    """numerator/denominator where `valid`, 0 elsewhere (finite gradients both ways)."""
    return jnp.where(valid, numerator / jnp.where(valid, denominator, 1), 0)


def closest_approach(separation, spring_1, spring_2) -> SegmentApproach:
    """Closest approach of segments P1 + t1 R1 and P2 + t2 R2, t ∈ [−½, ½] (exact; see
    the module docstring).

    Args:
        separation: (..., 3) d = P1 − P2, the midpoint separation (minimum image).
        spring_1, spring_2: (..., 3) spring vectors R1, R2.
    Returns:
        SegmentApproach; differentiable wherever the minimiser is unique.
    """
    a = _dot(spring_1, spring_1)
    e = _dot(spring_2, spring_2)
    b = _dot(spring_1, spring_2)
    c = _dot(spring_1, separation)
    f = _dot(spring_2, separation)
    half = jnp.asarray(0.5, separation.dtype)
    tiny = jnp.finfo(separation.dtype).tiny
    determinant = a * e - b * b
    # Δ below round-off of a e: parallel within precision; the edges hold the minimum.
    skew = determinant > 8 * jnp.finfo(separation.dtype).eps * a * e + tiny
    interior_1 = _safe_quotient(b * f - c * e, determinant, skew)
    interior_2 = _safe_quotient(a * f - b * c, determinant, skew)
    inside = skew & (jnp.abs(interior_1) <= half) & (jnp.abs(interior_2) <= half)

    def clip(t):
        return jnp.clip(t, -half, half)

    candidates = [(interior_1, interior_2)]
    for end in (-half, half):
        # t1 = end: minimise over t2 (e t2 = f + b t1); zero-length spring 2: t2 = 0.
        candidates.append((jnp.full_like(a, end), clip(_safe_quotient(f + b * end, e, e > tiny))))
    for end in (-half, half):
        # t2 = end: minimise over t1 (a t1 = b t2 − c).
        candidates.append((clip(_safe_quotient(b * end - c, a, a > tiny)), jnp.full_like(a, end)))
    t1 = jnp.stack([t for t, _ in candidates])
    t2 = jnp.stack([t for _, t in candidates])
    vectors = separation + t1[..., None] * spring_1 - t2[..., None] * spring_2
    squared = _dot(vectors, vectors)
    infinity = jnp.asarray(jnp.inf, squared.dtype)
    squared = squared.at[0].set(jnp.where(inside, squared[0], infinity))
    best = jnp.argmin(squared, axis=0)

    def pick(values):
        return jnp.take_along_axis(values, best[None], axis=0)[0]

    vector = jnp.take_along_axis(vectors, best[None, ..., None], axis=0)[0]
    distance_sq = pick(squared)
    positive = distance_sq > 0
    distance = jnp.where(positive, jnp.sqrt(jnp.where(positive, distance_sq, 1)), 0)
    return SegmentApproach(vector, distance, pick(t1), pick(t2))


# -- repulsion laws --------------------------------------------------------------------
def exponential_repulsion(distance, strength, decay, reach, floor):
    """Kumar–Larson force magnitude A α e^{−α max(D, D_min)} for D < D_c, else 0
    (thesis eq. 5.6).

    Args:
        distance: closest-approach distances D (any shape), units of r_c.
        strength: A (energy, k_BT).
        decay: α (1/r_c).
        reach: the range D_c beyond which the force is zero.
        floor: D_min, the smallest distance the force is evaluated at.
    Returns:
        f(D) (force), positive = repulsive.
    """
    floored = jnp.maximum(distance, floor)
    return jnp.where(distance < reach, strength * decay * jnp.exp(-decay * floored), 0)


def exponential_repulsion_energy(distance, strength, decay, reach, floor):
    """U(D) = A (e^{−α D} − e^{−α D_c}) for D_min ≤ D < D_c, 0 beyond, continued
    linearly with slope −f(D_min) below D_min; −dU/dD is `exponential_repulsion`."""
    floored = jnp.maximum(distance, floor)
    below = jnp.maximum(floor - distance, 0)
    energy = strength * (jnp.exp(-decay * floored) - math.exp(-decay * reach))
    energy = energy + strength * decay * jnp.exp(-decay * floor) * below
    return jnp.where(distance < reach, energy, 0)


def linear_repulsion(distance, a, reach, floor):
    """Pan–Manke force magnitude 3a (1 − max(D, D_min)/D_c) for D < D_c, else 0
    (thesis eq. 5.5).

    Args:
        distance: closest-approach distances D (any shape), units of r_c.
        a: the conservative coefficient a (force); the force at contact is 3a.
        reach: the range D_c (r_c/3 in the thesis).
        floor: D_min.
    Returns:
        f(D), positive = repulsive.
    """
    weight = 1 - jnp.maximum(distance, floor) / reach
    return jnp.where(distance < reach, 3 * a * weight, 0)


def linear_repulsion_energy(distance, a, reach, floor):
    """U(D) = (3/2) a D_c (1 − D/D_c)² for D_min ≤ D < D_c, 0 beyond, continued
    linearly below D_min; −dU/dD is `linear_repulsion`."""
    weight = 1 - jnp.maximum(distance, floor) / reach
    below = jnp.maximum(floor - distance, 0)
    energy = 1.5 * a * reach * weight * weight + 3 * a * (1 - floor / reach) * below
    return jnp.where(distance < reach, energy, 0)


@dataclass(frozen=True)
class SpringRepulsionLaw:
    """A spring–spring repulsion law with its parameters bound.

    Attributes:
        name: one of SPRING_REPULSION_LAWS.
        parameters: the scene's parameters of the law (name → value).
        reach: D_c, the distance from which on the force is zero (units of r_c).
        force: `force(distance) -> f`, elementwise, positive = repulsive.
        energy: `energy(distance) -> U`, elementwise, −dU/dD = f.
    """

    name: str
    parameters: dict
    reach: float
    force: Callable
    energy: Callable


def spring_repulsion_law(parameters: dict) -> SpringRepulsionLaw:
    """The law a scene's validated `[spring_repulsion]` table names.

    Args:
        parameters: {"law": "exponential", "A", "alpha", "range", "distance_floor"} or
            {"law": "linear", "a", "range", "distance_floor"} (other keys ignored).
    """
    name = parameters["law"]
    reach, floor = parameters["range"], parameters["distance_floor"]
    if name == "exponential":
        strength, decay = parameters["A"], parameters["alpha"]
        bound = {"A": strength, "alpha": decay}
        return SpringRepulsionLaw(
            name,
            bound,
            reach,
            lambda d: exponential_repulsion(d, strength, decay, reach, floor),
            lambda d: exponential_repulsion_energy(d, strength, decay, reach, floor),
        )
    if name == "linear":
        a = parameters["a"]
        return SpringRepulsionLaw(
            name,
            {"a": a},
            reach,
            lambda d: linear_repulsion(d, a, reach, floor),
            lambda d: linear_repulsion_energy(d, a, reach, floor),
        )
    raise ValueError(
        f"spring_repulsion.law = {name!r}: valid laws are {list(SPRING_REPULSION_LAWS)}"
    )


# -- springs of a scene and their pairs ----------------------------------------------------
@dataclass(frozen=True)
class SpringTable:
    """Every spring of the scene's chains, by the index of its first bead.

    Spring s joins beads starts[s] and starts[s] + 1.  Springs are numbered block by
    block, chain by chain, so two springs share a bead exactly when their first beads
    are adjacent (|starts[s] − starts[u]| = 1): the last spring of a chain and the
    first of the next differ by 2.

    Attributes:
        starts: (S,) int32 NumPy array (static).
    """

    starts: np.ndarray

    @property
    def count(self) -> int:
        """Number of springs S."""
        return int(self.starts.shape[0])

    def __hash__(self):
        return hash(self.starts.tobytes())

    def __eq__(self, other):
        return isinstance(other, SpringTable) and np.array_equal(self.starts, other.starts)


def spring_table(blocks) -> SpringTable:
    """The springs of linear-chain blocks (jaxdpd.geometry.chain_topology.ChainBlock)."""
    starts = [
        block.first + chain * block.beads + k
        for block in blocks
        for chain in range(block.n_chains)
        for k in range(block.beads - 1)
    ]
    return SpringTable(np.asarray(starts, np.int32))


def spring_vectors(bound_box, positions, table: SpringTable):
    """Spring vectors and midpoints.

    Args:
        bound_box: the box at this instant (minimum image, wrap).
        positions: (N, 3) wrapped bead positions.
        table: the springs.
    Returns:
        (springs (S, 3) minimum-image R = r_{k+1} − r_k, midpoints (S, 3)
        r_k + R/2 wrapped into the box).
    """
    starts = jnp.asarray(table.starts)
    first = positions[starts]
    springs = bound_box.minimum_image_vectors(positions[starts + 1] - first)
    midpoints, _ = bound_box.wrap(first + 0.5 * springs, jnp.zeros(first.shape, jnp.int32))
    return springs, midpoints


@pytree.dataclass
class SpringPairGeometry:
    """The closest approaches of listed spring pairs (traced, shape (P,) each).

    Attributes:
        beads_1, beads_2: (P,) int32 first beads k, l of the springs (clipped to valid).
        approach: SegmentApproach of spring 1 (beads k, k+1) to spring 2 (l, l+1).
        active: (P,) bool: listed, sharing no bead, and close enough by the centre
            distance that the springs may lie within `reach` (thesis fig. 5-3).
    """

    beads_1: jnp.ndarray
    beads_2: jnp.ndarray
    approach: SegmentApproach
    active: jnp.ndarray


def spring_pair_geometry(bound_box, springs, midpoints, table: SpringTable, i, j, reach: float):
    """Measure listed spring pairs.

    Pairs whose midpoints lie farther apart than (R1 + R2)/2 + reach cannot come
    within `reach` of each other (thesis fig. 5-3) and are marked inactive, as are
    pairs of springs that share a bead and empty list slots.

    Args:
        bound_box: the box at this instant (minimum image of the midpoint separation).
        springs, midpoints: (S, 3) from `spring_vectors`.
        table: the springs.
        i, j: (P,) int32 spring indices of the listed pairs (empty slots hold S).
        reach: the largest closest-approach distance of interest (units of r_c).
    Returns:
        SpringPairGeometry.
    """
    n_springs = table.count
    listed = (i < n_springs) & (j < n_springs)
    i = jnp.where(listed, i, 0)
    j = jnp.where(listed, j, 0)
    starts = jnp.asarray(table.starts)
    beads_1, beads_2 = starts[i], starts[j]
    separation = bound_box.minimum_image_vectors(midpoints[i] - midpoints[j])
    lengths = jnp.sqrt(jnp.sum(springs * springs, axis=-1))
    centre_sq = jnp.sum(separation * separation, axis=-1)
    screen = 0.5 * (lengths[i] + lengths[j]) + reach
    active = listed & (jnp.abs(beads_1 - beads_2) > 1) & (centre_sq < screen * screen)
    approach = closest_approach(separation, springs[i], springs[j])
    return SpringPairGeometry(beads_1, beads_2, approach, active)


def segment_forces(geometry: SpringPairGeometry, magnitude, n_particles: int):
    """Bead forces of the pair forces f D̂ shared with lever weights (module docstring).

    Args:
        geometry: from `spring_pair_geometry`.
        magnitude: (P,) force magnitudes f (0 where inactive), positive = repulsive.
        n_particles: N.
    Returns:
        (N, 3) forces.
    """
    approach = geometry.approach
    distance = approach.distance
    positive = distance > 0
    scale = jnp.where(positive, magnitude / jnp.where(positive, distance, 1), 0)
    force = scale[:, None] * approach.vector
    t1, t2 = approach.t1[:, None], approach.t2[:, None]
    indices = jnp.concatenate(
        [geometry.beads_1, geometry.beads_1 + 1, geometry.beads_2, geometry.beads_2 + 1]
    )
    shares = jnp.concatenate(
        [(0.5 - t1) * force, (0.5 + t1) * force, (t2 - 0.5) * force, -(0.5 + t2) * force]
    )
    return segment_sum_where(shares, indices, jnp.tile(geometry.active, 4), n_particles)


def segment_virial(geometry: SpringPairGeometry, magnitude):
    """Virial Σ_pairs D ⊗ f D̂ of the spring–spring forces, (3, 3) (each pair once)."""
    approach = geometry.approach
    distance = approach.distance
    positive = distance > 0
    scale = jnp.where(positive, magnitude / jnp.where(positive, distance, 1), 0)
    return dyadic_square(approach.vector, scale)


def pair_magnitudes(geometry: SpringPairGeometry, law: SpringRepulsionLaw):
    """f(D) of every active pair, 0 elsewhere."""
    return jnp.where(geometry.active, law.force(geometry.approach.distance), 0)


def pair_energy(geometry: SpringPairGeometry, law: SpringRepulsionLaw):
    """Total repulsion energy Σ_active U(D) (tests and diagnostics)."""
    return jnp.sum(jnp.where(geometry.active, law.energy(geometry.approach.distance), 0))
