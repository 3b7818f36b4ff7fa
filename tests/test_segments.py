"""Spring–spring closest approach, repulsion forces and the spring-pair list
(jaxdpd.forces.spring_repulsion, jaxdpd.geometry.neighbors.spring_pair_list; thesis §5.2)."""

import functools
import math

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from jaxdpd.forces.spring_repulsion import (
    SpringTable,
    closest_approach,
    pair_energy,
    pair_magnitudes,
    segment_forces,
    segment_virial,
    spring_pair_geometry,
    spring_repulsion_law,
    spring_vectors,
)
from jaxdpd.geometry.boxes import make_box
from jaxdpd.geometry.neighbors.spring_pair_list import SpringPairSearch, spring_pair_needs
from jaxdpd.observables.spring_pairs import spring_pair_distribution, spring_pair_samples
from jaxdpd.scene import Flow

LAWS = {
    "exponential": spring_repulsion_law(
        {"law": "exponential", "A": 100.0, "alpha": 10.0, "range": 1 / 3, "distance_floor": 1e-3}
    ),
    "linear": spring_repulsion_law(
        {"law": "linear", "a": 25.0, "range": 1 / 3, "distance_floor": 1e-3}
    ),
}


def brute_force_distance(separation, spring_1, spring_2, iterations: int = 60):
    """Reference: min over (t1, t2) ∈ [−½, ½]² of |D(t1, t2)| by nested golden-section
    searches (host-side float64).

    |D| is the norm of an affine function of (t1, t2), hence jointly convex, so
    g(t1) = min_t2 |D| is convex too and both searches converge to the global minimum.
    After 60 golden-ratio steps each bracket is 0.618^60 ≈ 3e-13 wide, so the distance
    found exceeds the true one by at most (|R1| + |R2|) × 3e-13 (|D| is Lipschitz in
    t with constant |R|); the bracket ends ±½ are tried too (a minimum on an edge).
    """
    d, r1, r2 = (np.asarray(v, np.float64) for v in (separation, spring_1, spring_2))
    ratio = (math.sqrt(5) - 1) / 2

    def golden(function):
        lo, hi = -0.5, 0.5
        for _ in range(iterations):
            m1, m2 = hi - ratio * (hi - lo), lo + ratio * (hi - lo)
            if function(m1) < function(m2):
                hi = m2
            else:
                lo = m1
        return min(function(t) for t in (-0.5, 0.5 * (lo + hi), 0.5))

    def over_t2(t1):
        point = d + t1 * r1
        return golden(lambda t2: math.sqrt(float(np.sum((point - t2 * r2) ** 2))))

    return golden(over_t2)


def special_pairs(rng):
    """(d, R1, R2) triples of the hard cases: crossing, parallel, antiparallel,
    nearly parallel (fig. 5-2), collinear end to end, T-shaped, zero length."""
    x, y, z = np.eye(3)
    unit = rng.normal(size=3)
    unit /= np.linalg.norm(unit)
    tilt = rng.normal(size=3) * 1e-7
    return [
        (0.0 * x, x, y),  # crossing at the midpoints, D = 0
        (0.2 * x + 0.1 * y, x, 0.7 * y),  # crossing off-centre, D = 0
        (0.3 * z, x, y),  # skew, perpendicular
        (0.2 * y, x, x),  # parallel, overlapping projections
        (0.2 * y + 0.9 * x, x, x),  # parallel, offset: end of one inside the other
        (0.2 * y + 1.7 * x, x, -x),  # antiparallel, projections disjoint
        (0.2 * y + 0.8 * x, x, x + tilt),  # nearly parallel (fig. 5-2)
        (0.05 * y + 0.95 * unit, unit, unit + tilt),  # nearly parallel, ends overlap
        (1.5 * x, x, 2 * x),  # collinear, end to end (touching: D = 0)
        (1.6 * x, x, 2 * x),  # collinear, a gap of 0.1
        (0.5 * x + 0.3 * y, x, y),  # T: an end of spring 1 against the inside of 2
        (0.3 * y + 0.1 * z, 0 * x, x),  # spring 1 of zero length (a point)
        (0.3 * y, 0 * x, 0 * x),  # both of zero length
    ]


def test_closest_approach_equals_brute_force_minimum():
    """|D| at the returned (t1, t2) equals the global minimum over the square from a
    derivative-free brute-force search (tolerance: the search's 3e-13 (|R1| + |R2|)
    bracket plus float64 rounding of |D| ≈ 1e-15 |d|, so 3e-12 absolute for |R| ≲ 4); D is
    d + t1 R1 − t2 R2 with t in [−½, ½]; for skew springs (unique minimiser) the t's
    agree with the brute force as well (checked by recomputing |D| at them)."""
    rng = np.random.default_rng(10)
    cases = special_pairs(rng)
    for _ in range(25):
        scale = rng.uniform(0.1, 1.5)
        cases.append(tuple(rng.normal(size=(3, 3)) * scale))
    d, r1, r2 = (np.stack(v) for v in zip(*cases, strict=True))
    approach = closest_approach(jnp.asarray(d), jnp.asarray(r1), jnp.asarray(r2))
    t1, t2 = np.asarray(approach.t1), np.asarray(approach.t2)
    vector = np.asarray(approach.vector)
    assert np.all(np.abs(t1) <= 0.5) and np.all(np.abs(t2) <= 0.5)
    np.testing.assert_allclose(vector, d + t1[:, None] * r1 - t2[:, None] * r2, atol=1e-14)
    np.testing.assert_allclose(np.asarray(approach.distance), np.linalg.norm(vector, axis=1))
    reference = np.asarray([brute_force_distance(*case) for case in cases])
    np.testing.assert_allclose(np.asarray(approach.distance), reference, rtol=0, atol=3e-12)
    # Known exact values of some special cases.
    np.testing.assert_allclose(
        np.asarray(approach.distance)[[0, 1, 2, 3, 8, 9]], [0, 0, 0.3, 0.2, 0, 0.1], atol=1e-14
    )


def random_chains(rng, n_chains: int, beads: int, bond: float, origin_spread: float):
    """Random-walk chains (bond length `bond`), starting within a cube."""
    starts = rng.uniform(0, origin_spread, size=(n_chains, 1, 3))
    steps = rng.normal(size=(n_chains, beads - 1, 3))
    steps *= bond / np.linalg.norm(steps, axis=-1, keepdims=True)
    walk = np.concatenate([np.zeros((n_chains, 1, 3)), np.cumsum(steps, axis=1)], axis=1)
    return (starts + walk).reshape(-1, 3)


def all_spring_pairs(table: SpringTable):
    i, j = np.triu_indices(table.count, k=1)
    return jnp.asarray(i, jnp.int32), jnp.asarray(j, jnp.int32)


def dense_chains(rng, box_lengths):
    """Four 6-bead chains packed around the box centre, wrapped into the box: springs
    near each other, many within the repulsion range, some across the boundary."""
    centre = np.asarray(box_lengths) / 2 - 1.0
    positions = random_chains(rng, 4, 6, 0.8, 2.0) + centre
    # Shift so that one chain straddles the x and z faces.
    positions[:6] += np.asarray(box_lengths) / 2 * (1, 0, 1)
    return positions % np.asarray(box_lengths)


def energy_and_forces(box, box_state, positions, law, table):
    i, j = all_spring_pairs(table)

    def geometry_at(x):
        bound_box = box.bind(box_state)
        springs, midpoints = spring_vectors(bound_box, x, table)
        return spring_pair_geometry(bound_box, springs, midpoints, table, i, j, law.reach)

    def energy(x):
        return pair_energy(geometry_at(x), law)

    @jax.jit
    def measured(x):
        geometry = geometry_at(x)
        magnitude = pair_magnitudes(geometry, law)
        forces = segment_forces(geometry, magnitude, x.shape[0])
        return magnitude, forces, segment_virial(geometry, magnitude)

    return (jax.jit(energy), *measured(positions))


BOXES = {
    "periodic": (make_box("periodic", (6.0, 6.0, 6.0)), None),
    "lees_edwards": (
        make_box("lees_edwards", (6.0, 6.0, 6.0), Flow(kind="shear", shear_rate=0.3)),
        "offset",
    ),
}


def bound(box_kind):
    box, offset = BOXES[box_kind]
    box_state = box.initial_state(jnp.float64)
    if offset is not None:
        box_state = box_state.__class__(
            offset=jnp.asarray(1.37), shear_rate=box_state.shear_rate, time=box_state.time
        )
    return box, box_state


@pytest.mark.parametrize(
    ("law_name", "box_kind"), [("exponential", "lees_edwards"), ("linear", "periodic")]
)
def test_forces_are_minus_the_energy_gradient(law_name, box_kind):
    """F_i = −∂U/∂r_i with U = Σ_pairs U(D_pair) (Danskin: the gradient at fixed
    closest points), checked against JAX autodiff of the energy through the
    closest-approach minimisation, the minimum image and the box (periodic, and
    Lees–Edwards at a nonzero offset); float64, so 1e-9 relative."""
    rng = np.random.default_rng(3)
    box, box_state = bound(box_kind)
    table = SpringTable(np.asarray([c * 6 + k for c in range(4) for k in range(5)], np.int32))
    positions = jnp.asarray(dense_chains(rng, box.lengths))
    law = LAWS[law_name]
    energy, magnitude, forces, _ = energy_and_forces(box, box_state, positions, law, table)
    interacting = int(np.sum(np.asarray(magnitude) > 0))
    assert interacting >= 3, "the configuration should hold interacting spring pairs"
    gradient = jax.grad(energy)(positions)
    scale = float(np.max(np.abs(np.asarray(forces))))
    np.testing.assert_allclose(np.asarray(forces), -np.asarray(gradient), atol=1e-9 * scale)


def test_four_bead_forces_conserve_momentum_and_angular_momentum():
    """Σ F = 0 and Σ r × F = 0 over the four beads of every pair, and the pair
    virial Σ r ⊗ F equals segment_virial's D ⊗ F (thesis §5.2: the force at the closest
    points shared with lever weights ½ ∓ t).  Chains in the middle of a large box (no
    boundary crossings, so r are the true positions); float64 rounding: 1e-12 × the
    largest force × position."""
    rng = np.random.default_rng(5)
    box = make_box("periodic", (30.0, 30.0, 30.0))
    table = SpringTable(np.asarray([c * 6 + k for c in range(4) for k in range(5)], np.int32))
    positions = random_chains(rng, 4, 6, 0.8, 1.5) + 14.0
    law = LAWS["exponential"]
    _, magnitude, forces, pair_virial = energy_and_forces(
        box, None, jnp.asarray(positions), law, table
    )
    forces = np.asarray(forces)
    assert np.sum(np.asarray(magnitude) > 0) >= 3
    scale = np.max(np.abs(forces)) * np.max(np.abs(positions))
    np.testing.assert_allclose(forces.sum(axis=0), 0, atol=1e-12 * scale)
    np.testing.assert_allclose(np.cross(positions, forces).sum(axis=0), 0, atol=1e-12 * scale)
    virial = np.einsum("ia,ib->ab", positions, forces)
    np.testing.assert_allclose(np.asarray(pair_virial), virial, atol=1e-12 * scale)


@pytest.mark.parametrize("law_name", sorted(LAWS))
def test_laws_force_is_minus_energy_derivative_and_floored(law_name):
    """f(D) = −dU/dD (autodiff, 1e-10 relative) on (0, D_c) across the floor; U = 0
    and f = 0 at and beyond D_c; below the floor D_min = 0.001 the force is f(D_min)
    (thesis §5.2.2); at contact the exponential law gives A α e^{−α D_min} (eq. 5.6)
    and the linear law 3a (1 − D_min/D_c) (eq. 5.5)."""
    law = LAWS[law_name]
    distances = jnp.linspace(1e-4, 0.5, 997)
    forces = law.force(distances)
    derivative = jax.vmap(jax.grad(lambda d: law.energy(d)))(distances)
    np.testing.assert_allclose(np.asarray(forces), -np.asarray(derivative), rtol=1e-10, atol=1e-10)
    beyond = np.asarray(distances) >= law.reach
    assert np.all(np.asarray(forces)[beyond] == 0) and np.all(
        np.asarray(law.energy(distances))[beyond] == 0
    )
    np.testing.assert_allclose(float(law.energy(law.reach * (1 - 1e-12))), 0, atol=1e-9)
    contact = float(law.force(jnp.asarray(0.0)))
    expected = 100 * 10 * math.exp(-10 * 1e-3) if law_name == "exponential" else 3 * 25 * (1 - 3e-3)
    assert contact == pytest.approx(expected, rel=1e-12)
    assert float(law.force(jnp.asarray(5e-4))) == pytest.approx(contact, rel=1e-12)


def test_springs_sharing_a_bead_are_excluded_but_chain_ends_are_not():
    """Adjacent springs of one chain (first beads k, k+1) never interact; the last
    spring of a chain and the first of the next (first beads differing by 2) do."""
    table = SpringTable(np.asarray([0, 1, 3], np.int32))  # chain 0..2, chain 3..4
    positions = jnp.asarray(
        [[1.0, 1.0, 1.0], [1.5, 1.0, 1.0], [1.5, 1.5, 1.0], [1.5, 1.0, 1.05], [1.5, 1.5, 1.05]]
    )
    box = make_box("periodic", (6.0, 6.0, 6.0))
    i, j = jnp.asarray([0, 0, 1]), jnp.asarray([1, 2, 2])
    springs, midpoints = spring_vectors(box, positions, table)
    geometry = spring_pair_geometry(box, springs, midpoints, table, i, j, 1 / 3)
    # (0, 1) share bead 1: excluded; (0, 2) 0.05 apart; (1, 2) share no bead (beads
    # 1–2 and 3–4) and lie 0.05 apart: active.
    assert np.asarray(geometry.active).tolist() == [False, True, True]


@functools.lru_cache(maxsize=8)
def jitted_refresh(search):
    """One compiled `search.refresh` per search (and list shape)."""
    return jax.jit(search.refresh)


def listed_near_pairs(search, spring_pairs, positions, box_state):
    """Refresh the list at `positions`: (refreshed list, {(s, u): active pairs of the
    list closer than the search's reach})."""
    spring_pairs, geometry = jitted_refresh(search)(positions, spring_pairs, box_state)
    near = np.asarray(geometry.active) & (np.asarray(geometry.approach.distance) < search.reach)
    i, j = np.asarray(spring_pairs.pairs.i)[near], np.asarray(spring_pairs.pairs.j)[near]
    return spring_pairs, set(zip(np.minimum(i, j).tolist(), np.maximum(i, j).tolist(), strict=True))


@functools.lru_cache(maxsize=8)
def every_pair_kernel(box, table, reach):
    """Jitted `(positions, box_state) -> SpringPairGeometry` of all S(S−1)/2 pairs."""
    i, j = all_spring_pairs(table)

    @jax.jit
    def kernel(x, box_state):
        bound_box = box.bind(box_state)
        springs, midpoints = spring_vectors(bound_box, x, table)
        return spring_pair_geometry(bound_box, springs, midpoints, table, i, j, reach)

    return kernel, np.asarray(i), np.asarray(j)


def exact_near_pairs(box, box_state, table, positions, reach):
    """{(s, u): s < u} of all spring pairs sharing no bead closer than `reach` (exact
    closest approach of every pair)."""
    kernel, i, j = every_pair_kernel(box, table, reach)
    every = kernel(positions, box_state)
    near = np.asarray(every.active) & (np.asarray(every.approach.distance) < reach)
    return set(zip(i[near].tolist(), j[near].tolist(), strict=True))


def chain_table(n_chains: int, beads: int) -> SpringTable:
    starts = [c * beads + k for c in range(n_chains) for k in range(beads - 1)]
    return SpringTable(np.asarray(starts, np.int32))


def test_spring_pair_list_holds_every_pair_within_reach():
    """The list built from midpoints within ℓ_L + D_c (+ skin), screened by the centre
    distance (fig. 5-3), marks active exactly the pairs whose exact closest approach
    (all S(S−1)/2 pairs, no bead shared) is below the reach, in a Lees–Edwards box
    at a nonzero offset (the periodic box: the overflow test below)."""
    rng = np.random.default_rng(11)
    box, box_state = bound("lees_edwards")
    positions = jnp.asarray(random_chains(rng, 12, 8, 0.7, 6.0) % 6.0)
    table = chain_table(12, 8)
    search = SpringPairSearch(box, table, 0.5, 0.3, 0.75)
    spring_pairs = search.allocate(positions, box_state)
    _, found = listed_near_pairs(search, spring_pairs, positions, box_state)
    expected = exact_near_pairs(box, box_state, table, positions, search.reach)
    assert len(expected) > 20
    assert found == expected


def test_spring_pair_list_overflow_is_flagged_and_cured_by_reallocation():
    """A spring stretched beyond the listed length ℓ_L, then also springs crowded into
    one cell beyond its capacity, set the list's overflow; a list allocated with the
    recorded needs (what the driver does) holds every near pair again."""
    rng = np.random.default_rng(12)
    box, box_state = bound("periodic")
    chains = random_chains(rng, 12, 8, 0.7, 6.0)
    table = chain_table(12, 8)
    search = SpringPairSearch(box, table, 0.5, 0.3, 0.75)
    spring_pairs = search.allocate(jnp.asarray(chains % 6.0), box_state)
    stretched = chains.copy()
    bond = stretched[7] - stretched[6]
    stretched[7] = stretched[6] + 1.6 * bond / np.linalg.norm(bond)  # chain 0's last spring
    crowded = stretched.copy()
    crowded[8:56] = 1.0 + 0.15 * (chains[8:56] - chains[8:56].mean(axis=0))  # into one cell
    for moved in (stretched, crowded):
        refreshed, _ = listed_near_pairs(search, spring_pairs, jnp.asarray(moved % 6.0), box_state)
        assert bool(refreshed.overflow)
    assert float(refreshed.longest) == pytest.approx(1.6)
    assert int(refreshed.pairs.needed_cell_occupancy) > refreshed.pairs.cell_capacity
    positions = jnp.asarray(crowded % 6.0)
    grown = search.allocate(positions, box_state, spring_pair_needs(refreshed))
    grown, found = listed_near_pairs(search, grown, positions, box_state)
    assert not bool(grown.overflow)
    assert found == exact_near_pairs(box, box_state, table, positions, search.reach)


def onsager_excluded_volume(distance, length):
    """Volume of relative positions (isotropic orientations) in which two segments of
    length ℓ come closer than D: the excluded volume of spherocylinders of diameter D,
    (4π/3) D³ + 2π ℓ D² + (π/2) ℓ² D (Onsager, Ann. N.Y. Acad. Sci. 51, 627 (1949),
    with ⟨|sin γ|⟩ = π/4)."""
    return (
        4 * math.pi / 3 * distance**3
        + 2 * math.pi * length * distance**2
        + (math.pi / 2 * length**2 * distance)
    )


def test_spring_pair_histogram_of_random_rods_follows_onsager_excluded_volume():
    """S unit springs (dimers) placed and oriented uniformly at random: the expected
    number of pairs closer than D is S(S − 1)/2 · V_ex(D)/V (Onsager's excluded
    volume); the histogram of the "spring_pairs" observable, accumulated over the
    spring-pair list, must match it cumulatively at every bin edge, and
    `spring_pair_distribution` must integrate to 2 × pairs / S.  Tolerance: the
    counts are sums of nearly independent rare pair events (Poisson, variance ≈
    mean), so 4 standard deviations of the count at each edge."""
    rng = np.random.default_rng(21)
    n_springs, length, edge, reach, bins = 1500, 1.0, 9.0, 0.5, 10
    box = make_box("periodic", (edge, edge, edge))
    first = rng.uniform(0, edge, size=(n_springs, 3))
    direction = rng.normal(size=(n_springs, 3))
    direction /= np.linalg.norm(direction, axis=1, keepdims=True)
    positions = np.stack([first, first + length * direction], axis=1).reshape(-1, 3) % edge
    positions = jnp.asarray(positions)
    table = SpringTable(np.arange(0, 2 * n_springs, 2, dtype=np.int32))
    search = SpringPairSearch(box, table, reach, 0.0, length)
    spring_pairs = search.allocate(positions)

    @jax.jit
    def histogram(x, spring_pairs):
        _, geometry = search.refresh(x, spring_pairs)
        samples = spring_pair_samples(geometry, geometry, reach, bins, jnp.float64)
        return samples["spring_pairs/histogram"]

    counts = np.asarray(histogram(positions, spring_pairs))
    edges = np.linspace(0, reach, bins + 1)[1:]
    expected = n_springs * (n_springs - 1) / 2 * onsager_excluded_volume(edges, length) / edge**3
    cumulative = np.cumsum(counts)
    assert expected[-1] > 1000
    np.testing.assert_array_less(np.abs(cumulative - expected), 4 * np.sqrt(expected) + 1)
    centres, density = spring_pair_distribution(counts, reach, n_springs)
    width = reach / bins
    assert np.sum(density) * width == pytest.approx(2 * cumulative[-1] / n_springs, rel=1e-12)
    np.testing.assert_allclose(centres, edges - width / 2)
