"""Kraynik–Reinelt geometry: lattice cases, reduced cells, separations, neighbour sets,
wrapping and resets (thesis §3.4.2–3.4.3, table 3.27; Kraynik & Reinelt, Int. J.
Multiphase Flow 18, 1045 (1992)).

Reference for separations: a brute-force search over the images of the lattice in
the thesis's own basis F(ε) A0 (the tilted square stretched by the total strain ε,
not reduced), r_j + n0 a1 + n2 a2 + ny L_y ŷ with |n0|, |n2| ≤ 3, |ny| ≤ 1: the
shortest image vector of every pair (the search range is checked to contain it).
"""

import math

import jax
import jax.numpy as jnp
import numpy as np
import pytest

# The cell list's pairs within the cut-off, as the Lees–Edwards tests collect them.
from test_lees_edwards_geometry import CUTOFF, listed_pairs

from jaxdpd.geometry.boxes import KraynikReineltBox
from jaxdpd.geometry.boxes.kraynik_reinelt_lattice import kraynik_reinelt_case, stretch
from jaxdpd.geometry.neighbors.cell_list import cell_list_search

LENGTHS = (6.0, 4.0, 6.0)
N = 300
# Thesis table 3.27: (ε_p, θ) as printed.
TABLE_3_27 = {
    1: (0.96242, 0.553574),
    2: (1.762747, 0.392699),
    3: (2.389526, 0.294001),
    4: (2.703576, 0.613886),
}
SEARCH = 3


def thesis_lattice(case, side, strain):
    """(2, 2) the thesis's basis F(ε) A0 (columns a1, a2 in (x, z)) at total strain ε."""
    return stretch(strain) @ (side * np.asarray(kraynik_reinelt_case(case).cell))


def brute_force_pairs(positions, case, strain, cutoff):
    """{(i, j): shortest image vector r_i − r_j} for pairs closer than the cut-off."""
    side, length_y, _ = LENGTHS
    lattice = thesis_lattice(case, side, strain)
    shifts, edge = [], []
    for n0 in range(-SEARCH, SEARCH + 1):
        for n2 in range(-SEARCH, SEARCH + 1):
            x, z = lattice @ (n0, n2)
            for ny in (-1, 0, 1):
                shifts.append((x, ny * length_y, z))
                edge.append(max(abs(n0), abs(n2)) == SEARCH)
    shifts, edge = np.asarray(shifts), np.asarray(edge)
    i, j = np.triu_indices(len(positions), 1)
    images = (positions[i] - positions[j])[:, None, :] - shifts[None]
    lengths_sq = np.sum(images**2, axis=-1)
    best = np.argmin(lengths_sq, axis=1)
    rows = np.arange(len(i))
    close = lengths_sq[rows, best] < cutoff**2
    assert not np.any(edge[best[close]]), "widen the image search"
    vectors = images[rows, best][close]
    return {(int(a), int(b)): v for a, b, v in zip(i[close], j[close], vectors, strict=True)}


def state_at(box, strain, dtype=jnp.float64):
    return box.initial_state(dtype).set(strain=jnp.asarray(strain, dtype))


def cell_positions(box, box_state, fractions):
    """Cartesian positions of fractional coordinates (N, 3) in the primary cell."""
    lattice = np.asarray(box.bind(box_state).lattice_vectors)
    return np.asarray(box.centre) + (fractions - 0.5) @ lattice.T


@pytest.mark.parametrize("case", [1, 2, 3, 4])
def test_cases_reproduce_table_3_27_and_map_the_lattice_onto_itself(case):
    """ε_p and θ agree with the printed digits of thesis table 3.27, and F(ε_p) maps
    the tilted square lattice onto itself: A0⁻¹ F(ε_p) A0 is an integer matrix of
    determinant 1 (the condition of Kraynik & Reinelt)."""
    geometry = kraynik_reinelt_case(case)
    period, angle = TABLE_3_27[case]
    assert abs(geometry.period - period) <= 5e-6
    assert abs(geometry.angle - angle) <= 5e-7
    cell = np.asarray(geometry.cell)
    reset = np.linalg.solve(cell, stretch(geometry.period) @ cell)
    np.testing.assert_allclose(reset, np.round(reset), atol=1e-12)
    assert round(np.linalg.det(reset)) == 1
    # θ is the angle between a lattice vector and the stretching axis z.
    assert math.isclose(math.atan2(cell[0, 0], cell[1, 0]), angle, abs_tol=5e-7)


@pytest.mark.parametrize("case", [1, 2, 3, 4])
def test_primary_cells_are_reduced_bases_of_the_flowing_lattice(case):
    """At 4001 strains across a period the box's cell spans the lattice of the thesis
    basis F(ε) A0 (an integer unimodular change of basis), is Lagrange–Gauss reduced
    (|b1·b2| ≤ ½ min |b|²: nothing shorter can replace a vector) and is never thinner
    than the static `cell_heights`, which the sampled minimum meets to 1e-3."""
    box = KraynikReineltBox(LENGTHS, 0.1, case)
    side = LENGTHS[0]
    period = box.period
    strains = np.linspace(-period / 2, period / 2, 4001)[:-1]
    lattices = np.asarray(
        jax.vmap(lambda s: box.bind(state_at(box, s)).lattice)(jnp.asarray(strains))
    )
    heights = []
    for strain, cell in zip(strains, lattices, strict=True):
        change = np.linalg.solve(thesis_lattice(case, side, strain), cell)
        np.testing.assert_allclose(change, np.round(change), atol=1e-9)
        assert abs(round(np.linalg.det(change))) == 1
        b0, b2 = cell[:, 0], cell[:, 1]
        assert abs(b0 @ b2) <= 0.5 * min(b0 @ b0, b2 @ b2) * (1 + 1e-9)
        area = abs(np.linalg.det(cell))
        heights.append((area / np.linalg.norm(b2), area / np.linalg.norm(b0)))
    heights = np.min(heights, axis=0)
    static = np.asarray(box.cell_heights)[[0, 2]]
    assert np.all(heights >= static)
    np.testing.assert_allclose(heights, static, rtol=1e-3)
    # Thicker than the thesis's cell over [0, ε_p) (thinnest L/√5 for case 1).
    thesis = min(
        side**2 / np.linalg.norm(thesis_lattice(case, side, s), axis=0).max()
        for s in np.linspace(0, period, 401)
    )
    assert static.min() > thesis


@pytest.fixture(scope="module")
def elongated():
    box = KraynikReineltBox(LENGTHS, 0.5, 1)
    return box, cell_list_search(box, N, CUTOFF, 0.0)


def strains_to_check():
    """Both sides of the reset and of every change of cell, and zero strain (case 1)."""
    geometry = kraynik_reinelt_case(1)
    half = geometry.period / 2
    points = [-half + 1e-9, 0.0, half - 1e-9]
    for switch in geometry.switch_strains:
        points += [switch - 1e-9, switch + 1e-9]
    return points


@pytest.mark.parametrize("strain", strains_to_check())
def test_pairs_across_the_deforming_boundaries_match_brute_force(elongated, strain):
    """Same neighbour set (each pair once) and separation vectors as the image search,
    at strains across a period, on both sides of every reset and change of cell."""
    box, search = elongated
    fractions = np.random.default_rng(3).uniform(size=(N, 3))
    box_state = state_at(box, strain)
    positions = cell_positions(box, box_state, fractions)
    found = listed_pairs(box, search, jnp.asarray(positions), box_state)
    expected = brute_force_pairs(positions, 1, strain, CUTOFF)
    assert set(found) == set(expected)
    for key, vector in expected.items():
        np.testing.assert_allclose(found[key], vector, atol=1e-12)
    across = [k for k in expected if np.linalg.norm(positions[k[0]] - positions[k[1]]) > 2]
    assert len(across) > 20  # the boundaries really were crossed


def transitions():
    """(name, strain before, strain after) of the reset and each change of cell."""
    geometry = kraynik_reinelt_case(1)
    half = geometry.period / 2
    steps = [("reset", half - 1e-12, -half + 1e-12)]
    steps += [(f"switch {s:.4f}", s - 1e-12, s + 1e-12) for s in geometry.switch_strains]
    return steps


@pytest.mark.parametrize("name, before, after", transitions())
def test_reset_and_change_of_cell_keep_every_particle_relation(name, before, after):
    """Across the Kraynik–Reinelt reset (strain ε_p/2 → −ε_p/2) and each change of
    reduced cell, the wrap moves particles by lattice vectors only, into the new cell,
    and leaves every minimum-image separation below half the thinnest height as it
    was.  The reduced cell is continuous across the reset itself (M U_last = U_first),
    so there no particle moves at all; at a change of cell many do."""
    box = KraynikReineltBox(LENGTHS, 0.5, 1)
    state_before = state_at(box, before)
    state_after = box.advance(state_before, 0.0, (after - before) / 0.5)
    assert abs(float(state_after.strain) - after) < 1e-12
    fractions = np.random.default_rng(5).uniform(size=(N, 3))
    positions = jnp.asarray(cell_positions(box, state_before, fractions))
    bound = box.bind(state_after)
    wrapped, image = bound.wrap(positions, jnp.zeros((N, 3), jnp.int32))
    lattice = np.asarray(bound.lattice_vectors)
    steps = np.linalg.solve(lattice, np.asarray(wrapped - positions).T).T
    np.testing.assert_allclose(steps, np.round(steps), atol=1e-9)
    np.testing.assert_array_equal(np.round(steps), -np.asarray(image))
    moved = np.count_nonzero(np.any(np.asarray(image) != 0, axis=1))
    assert moved == 0 if name == "reset" else moved > N // 10
    inside = np.linalg.solve(lattice, (np.asarray(wrapped) - np.asarray(box.centre)).T).T
    assert np.all(np.abs(inside) <= 0.5 + 1e-12)
    i, j = np.triu_indices(N, 1)
    old = box.bind(state_before).minimum_image_vectors(positions[i] - positions[j])
    new = bound.minimum_image_vectors(wrapped[i] - wrapped[j])
    short = np.linalg.norm(np.asarray(old), axis=1) < 0.5 * min(box.cell_heights)
    np.testing.assert_allclose(np.asarray(new)[short], np.asarray(old)[short], atol=1e-11)


def test_crossing_a_deforming_face_moves_by_a_lattice_vector():
    """A particle past the face of frame axis 0 re-enters at r − b0, one past y = L_y
    at y − L_y; the counters say which faces; particles inside are left bit for bit."""
    box = KraynikReineltBox(LENGTHS, 0.5, 1)
    bound = box.bind(state_at(box, 0.3))
    lattice = np.asarray(bound.lattice_vectors)
    centre = np.asarray(box.centre)
    fractions = np.array([[1.1, 0.3, 0.4], [0.2, 1.05, -0.3], [0.25, 0.5, 0.75]])
    positions = jnp.asarray(centre + (fractions - 0.5) @ lattice.T)
    wrapped, image = bound.wrap(positions, jnp.zeros((3, 3), jnp.int32))
    np.testing.assert_allclose(wrapped[0], positions[0] - lattice[:, 0], atol=1e-12)
    np.testing.assert_allclose(wrapped[1], positions[1] - lattice[:, 1] + lattice[:, 2], atol=1e-12)
    np.testing.assert_array_equal(image, [[1, 0, 0], [0, 1, -1], [0, 0, 0]])
    assert np.array_equal(np.asarray(wrapped[2]), np.asarray(positions[2]))


def test_springs_are_their_own_minimum_image_and_long_ones_are_flagged():
    """Vectors shorter than half the thinnest height, shifted by large lattice vectors,
    come back exactly at every strain; `springs_past_half_box` flags an x–z part over
    SPRING_LIMIT of the thinnest in-plane height or a y part over SPRING_LIMIT L_y."""
    box = KraynikReineltBox(LENGTHS, 0.5, 1)
    rng = np.random.default_rng(11)
    limit = 0.5 * min(box.cell_heights)
    directions = rng.normal(size=(500, 3))
    vectors = directions / np.linalg.norm(directions, axis=1, keepdims=True)
    vectors *= limit * rng.uniform(0.0, 0.999, size=(500, 1))
    for strain in (-0.48, -0.2406, 0.0, 0.3, 0.4812):
        bound = box.bind(state_at(box, strain))
        shifts = rng.integers(-5, 6, size=(500, 3)) @ np.asarray(bound.lattice_vectors).T
        back = bound.minimum_image_vectors(jnp.asarray(vectors + shifts))
        np.testing.assert_allclose(np.asarray(back), vectors, atol=1e-11)
    height_xz = 0.45 * min(box.cell_heights[0], box.cell_heights[2])
    flag = bound.springs_past_half_box
    zero = jnp.zeros((1, 3), jnp.int32)
    assert not bool(flag(None, jnp.asarray([[0.99 * height_xz, 0.0, 0.0]]), zero))
    assert bool(flag(None, jnp.asarray([[0.0, 0.0, 1.01 * height_xz]]), zero))
    assert not bool(flag(None, jnp.asarray([[0.0, 0.44 * LENGTHS[1], 0.0]]), zero))
    assert bool(flag(None, jnp.asarray([[0.0, 0.46 * LENGTHS[1], 0.0]]), zero))


def test_strain_stays_bounded_over_200_periods_in_float32():
    """ε̇ Δt = 0.02 for 200 periods (192.5 Hencky strains, 9625 steps) in float32: the
    strain is kept modulo ε_p in [−ε_p/2, ε_p/2), and ends where the float64 sum of
    the same float32 increments puts it, within the round-off of each addition (half
    an ulp of |ε| < 0.5, 3e-8 per step)."""
    box = KraynikReineltBox(LENGTHS, 0.5, 1)
    steps, dt = 9625, 0.04

    @jax.jit
    def strain(state):
        return jax.lax.fori_loop(0, steps, lambda _, s: box.advance(s, 0.0, dt), state)

    state = strain(box.initial_state(jnp.float32))
    assert state.strain.dtype == jnp.float32
    period = box.period
    assert -period / 2 <= float(state.strain) < period / 2
    increment = float(np.float32(0.5) * np.float32(dt))
    exact = (increment * steps + period / 2) % period - period / 2
    assert abs(float(state.strain) - exact) < steps * 0.5 * np.spacing(np.float32(0.5))
    assert increment * steps / period > 200


def within_pairs(positions, lattice, cutoff):
    """Set of pairs (i < j) closer than `cutoff` over the 27 images of a cell."""
    shifts = np.array([(a, b, c) for a in (-1, 0, 1) for b in (-1, 0, 1) for c in (-1, 0, 1)])
    i, j = np.triu_indices(len(positions), 1)
    images = (positions[i] - positions[j])[:, None] - (shifts @ lattice.T)[None]
    close = np.min(np.sum(images**2, axis=-1), axis=1) < cutoff**2
    return set(zip(i[close].tolist(), j[close].tolist(), strict=True))


def test_skin_criterion_never_misses_a_pair_while_the_lattice_deforms():
    """Verlet-list soundness (jaxdpd.geometry.neighbors.pair_list.needs_rebuild with
    `image_drift`): pairs within r_c + skin are listed at a reference strain; the
    lattice then deforms through a strain Δε while the particles move by random
    displacements, either streaming with the lattice or not at all (the criterion
    must hold for any motion), and are wrapped.  Whenever the criterion says the list
    is still good, every pair now within r_c is in it.  The same trials judged without
    the drift term do miss pairs, so they reach the regime where the term matters."""
    from types import SimpleNamespace

    from jaxdpd.geometry.neighbors.pair_list import needs_rebuild

    box = KraynikReineltBox((4.5, 3.0, 4.5), 1.0, 1)
    skin, n = 0.4, 120
    rng = np.random.default_rng(17)
    kept = missed_without_drift = 0
    for trial in range(40):
        reference = state_at(box, rng.uniform(-box.period / 2, box.period / 2))
        positions = cell_positions(box, reference, rng.uniform(size=(n, 3)))
        listed = within_pairs(positions, np.asarray(box.bind(reference).lattice_vectors), 1 + skin)
        change = rng.uniform(-0.1, 0.1)
        now = box.advance(reference, 0.0, change)
        centre = np.asarray(box.centre)
        streamed = change * (trial % 2)
        moved = centre + (positions - centre) @ np.diag([np.exp(-streamed), 1, np.exp(streamed)])
        moved += rng.normal(scale=0.02, size=moved.shape)
        bound = box.bind(now)
        lattice_now = np.asarray(bound.lattice_vectors)
        wrapped, _ = bound.wrap(jnp.asarray(moved), jnp.zeros((n, 3), jnp.int32))
        pair_list = SimpleNamespace(
            reference_positions=jnp.asarray(positions), reference_box_state=reference
        )
        close = within_pairs(np.asarray(wrapped), lattice_now, 1)
        if not bool(needs_rebuild(box, wrapped, pair_list, now, skin)):
            kept += 1
            assert close <= listed, (trial, change)
        displaced = bound.minimum_image_vectors(wrapped - pair_list.reference_positions)
        if 2 * float(jnp.max(jnp.linalg.norm(displaced, axis=1))) <= skin:
            missed_without_drift += not close <= listed
    assert kept >= 10 and missed_without_drift >= 1, (kept, missed_without_drift)


@pytest.mark.parametrize("strain", [-0.4, 0.0, 0.3])
def test_h5md_edges_are_the_current_lattice(strain):
    """The H5MD `edges` of a Kraynik–Reinelt box (jaxdpd.io.h5md.box_edges) are three
    rows spanning the flowing lattice: the x–z rows are an integer unimodular change
    of the thesis basis F(ε) A0, the y row is (0, L_y, 0), and |det| is the conserved
    volume L² L_y."""
    from jaxdpd.io.h5md import box_edges

    box = KraynikReineltBox(LENGTHS, 0.1, 1)
    edges = box_edges(box.bind(state_at(box, strain)))
    assert edges.shape == (3, 3) and edges.dtype == np.float64
    np.testing.assert_allclose(edges[1], [0.0, LENGTHS[1], 0.0], atol=1e-12)
    in_plane = edges[[0, 2]][:, [0, 2]].T  # columns: the two x–z lattice vectors
    np.testing.assert_allclose(edges[[0, 2], 1], 0.0, atol=1e-12)
    change = np.linalg.solve(thesis_lattice(1, LENGTHS[0], strain), in_plane)
    np.testing.assert_allclose(change, np.round(change), atol=1e-9)
    assert abs(round(np.linalg.det(change))) == 1
    assert math.isclose(abs(np.linalg.det(edges)), box.volume, rel_tol=1e-12)
