"""Neighbour lists against a brute-force O(N²) minimum-image search."""

import itertools
from fractions import Fraction

import jax
import jax.numpy as jnp
import numpy as np
import pytest
from conftest import scene_dict

from jaxdpd.forces.pair_sums import pair_geometry
from jaxdpd.geometry.boxes import PeriodicBox
from jaxdpd.geometry.neighbors import neighbor_search
from jaxdpd.geometry.neighbors.cell_list import cell_grid, crowd_capacity, dense_tier
from jaxdpd.scene import Scene, cube_root


def brute_force_pairs(positions, lengths, cutoff):
    """All pairs i < j with minimum-image distance < cutoff, and their separations.

    The minimum image is found by searching the images explicitly (not by rounding):
    in a box at rest the squared distance is a sum over the axes, so the nearest of
    the 27 images is the nearest of the three shifts −L, 0, L along each axis.  It is
    an independent reference.

    Returns:
        dict (i, j) -> separation r_i − r_j of the nearest image.
    """
    positions = np.asarray(positions, np.float64)
    lengths = np.asarray(lengths, np.float64)
    n = len(positions)
    shifts = np.array([-1.0, 0.0, 1.0])
    found = {}
    for start in range(0, n, 256):
        rows = np.arange(start, min(n, start + 256))
        d = positions[rows, None, :] - positions[None, :, :]  # (rows, n, 3)
        images = d[..., None] + shifts * lengths[:, None]  # (rows, n, 3 axes, 3 shifts)
        best = np.argmin(images**2, axis=-1)
        nearest = np.take_along_axis(images, best[..., None], -1)[..., 0]  # (rows, n, 3)
        r_sq = np.sum(nearest**2, axis=-1)
        a, b = np.nonzero((r_sq < cutoff**2) & (rows[:, None] < np.arange(n)[None, :]))
        found.update(
            zip(zip(rows[a].tolist(), b.tolist(), strict=True), nearest[a, b], strict=True)
        )
    return found


def listed_pairs(pair_list, n):
    i = np.asarray(pair_list.i)
    j = np.asarray(pair_list.j)
    keep = i < n
    return {(min(a, b), max(a, b)) for a, b in zip(i[keep], j[keep], strict=True)}


CONFIGURATIONS = [
    # (lengths, N, cutoff, skin): cubic, elongated, single-cell axes, skin, and cells
    # of 36 particles on average (a dense tier of 42 slots: two lanes per offset)
    ((8.0, 8.0, 8.0), 1536, 1.0, 0.0),
    ((12.0, 5.0, 6.5), 1170, 1.0, 0.3),
    ((2.5, 9.0, 2.8), 190, 1.0, 0.2),
    ((7.0, 7.0, 7.0), 1029, 1.3, 0.5),
    ((4.0, 4.0, 4.0), 2304, 1.0, 0.0),
]


CASES = [(*configuration, "cell_list", None) for configuration in CONFIGURATIONS] + [
    (*CONFIGURATIONS[1], "jax_md", fmt) for fmt in ("dense", "sparse", "ordered_sparse")
]


@pytest.mark.parametrize(("lengths", "n", "cutoff", "skin", "method", "fmt"), CASES)
def test_pair_set_and_separations_match_brute_force(lengths, n, cutoff, skin, method, fmt):
    rng = np.random.default_rng(n)
    positions = rng.uniform(0, 1, (n, 3)) * np.asarray(lengths)
    # Put some particles exactly on the faces and corners of the box.
    positions[:8] = np.array(list(itertools.product((0.0, 1e-12), repeat=3))) * lengths
    box = PeriodicBox(lengths)
    search = neighbor_search(box, n, cutoff, skin, method, fmt or "ordered_sparse")
    positions = jnp.asarray(positions, jnp.float64)
    pair_list = search.allocate(positions)
    assert not bool(pair_list.overflow)
    reference = brute_force_pairs(positions, lengths, cutoff + skin)
    assert listed_pairs(pair_list, n) == set(reference)
    if not search.half:
        i, j = np.asarray(pair_list.i), np.asarray(pair_list.j)
        listed = i < n
        assert listed.sum() == 2 * len(reference)
    # Separations measured by the pair kernel equal the brute-force minimum images.
    geometry = pair_geometry(box, positions, pair_list, cutoff + skin, search.half)
    i, j = np.asarray(geometry.i), np.asarray(geometry.j)
    within = np.asarray(geometry.within)
    separation = np.stack([np.asarray(s) for s in geometry.separation], axis=1)
    expected = np.array(
        [
            reference[(a, b)] if a < b else -reference[(b, a)]
            for a, b in zip(i[within].tolist(), j[within].tolist(), strict=True)
        ]
    )
    np.testing.assert_allclose(separation[within], expected, atol=1e-12)


def test_skin_rebuilds_only_when_a_particle_moved_half_the_skin():
    lengths = (6.0, 6.0, 6.0)
    n = 648
    box = PeriodicBox(lengths)
    search = neighbor_search(box, n, 1.0, 0.4)
    rng = np.random.default_rng(1)
    positions = jnp.asarray(rng.uniform(0, 6.0, (n, 3)))
    pair_list = search.allocate(positions)
    update = jax.jit(search.update)
    nudged = positions.at[0, 0].add(0.19)  # < skin/2: keep the list
    assert int(update(nudged, pair_list).rebuilds) == 0
    moved = positions.at[0, 0].add(0.21)  # > skin/2: rebuild
    rebuilt = update(moved, pair_list)
    assert int(rebuilt.rebuilds) == 1
    assert listed_pairs(rebuilt, n) == set(brute_force_pairs(moved, lengths, 1.4))
    # Displacements across the periodic boundary count by their minimum image.
    wrapped = positions.at[0, 0].set(jnp.mod(positions[0, 0] + 5.9, 6.0))
    assert int(update(wrapped, pair_list).rebuilds) == 0


def test_overflow_is_flagged_and_needs_are_recorded():
    lengths = (6.0, 6.0, 6.0)
    n = 300
    box = PeriodicBox(lengths)
    search = neighbor_search(box, n, 1.0, 0.0)
    rng = np.random.default_rng(2)
    sparse = jnp.asarray(rng.uniform(0, 6.0, (n, 3)))
    pair_list = search.allocate(sparse, 1.0)
    update = jax.jit(search.update)
    # Too few pair slots: the exact number needed is recorded.
    short = pair_list.set(i=pair_list.i[:100], j=pair_list.j[:100])
    updated = update(sparse, short)
    assert bool(updated.overflow)
    assert int(updated.needed_pairs) == len(brute_force_pairs(sparse, lengths, 1.0))
    # Squeeze all particles into one corner: the cells overflow; the fullest cell is
    # recorded (the pair count is then only a lower bound) and reallocation recounts.
    crowded = sparse * 0.5
    updated = update(crowded, pair_list)
    assert bool(updated.overflow)
    assert int(updated.needed_cell_occupancy) > pair_list.cell_capacity
    bigger = search.allocate(
        crowded, 1.0, minimum=(int(updated.needed_pairs), int(updated.needed_cell_occupancy))
    )
    assert not bool(bigger.overflow)
    assert listed_pairs(bigger, n) == set(brute_force_pairs(crowded, lengths, 1.0))


def clustered_positions(rng, n, clusters, per_cluster, per_other):
    """`clusters` unit cells of a 6³ box holding `per_cluster` particles each (in a
    0.3-wide corner of the cell), the others `per_other` to a remaining cell."""
    cells = np.array(list(itertools.product(range(6), repeat=3)), np.float64)
    order = rng.permutation(len(cells))
    crowded_cells, other_cells = cells[order[:clusters]], cells[order[clusters:]]
    crowded = np.repeat(crowded_cells, per_cluster, axis=0) + 0.1
    crowded += rng.uniform(0, 0.3, crowded.shape)
    rest = n - len(crowded)
    assert rest <= per_other * len(other_cells)
    others = np.repeat(other_cells, per_other, axis=0)[:rest]
    others += rng.uniform(0.05, 0.95, others.shape)
    return jnp.asarray(np.concatenate([crowded, others]))


def test_crowded_particles_are_listed_and_too_many_ask_for_larger_cells():
    """Particles above the dense tier of their cell (cell_list's module docstring)
    are found by a separate gather path, in an order that does not depend on the
    buffer sizes; more of them than the buffers hold flag an overflow whose recorded
    occupancy, on reallocation, makes room for them."""
    lengths = (6.0, 6.0, 6.0)
    n = 600
    box = PeriodicBox(lengths)
    search = neighbor_search(box, n, 1.0, 0.0)
    rng = np.random.default_rng(3)
    pair_list = search.allocate(jnp.asarray(rng.uniform(0, 6.0, (n, 3))))
    capacity = pair_list.cell_capacity
    dense = dense_tier(n, 216)
    room = crowd_capacity(n, capacity, dense)
    per_cluster = capacity  # the cells themselves do not overflow
    crowded_per_cluster = capacity - dense
    update = jax.jit(search.update)
    # Crowded particles within the room: listed exactly once, like the others.
    few = clustered_positions(rng, n, 3, per_cluster, dense - 1)
    assert 0 < 3 * crowded_per_cluster <= room
    listed = update(few, pair_list)
    assert not bool(listed.overflow)
    pairs = listed_pairs(listed, n)
    assert len(pairs) == int((np.asarray(listed.i) < n).sum())  # no pair twice
    assert pairs == set(brute_force_pairs(few, lengths, 1.0))
    # The same pairs in the same order from buffers of another size.
    larger = search.allocate(few, 2.0, minimum=(0, capacity + 5))
    assert larger.cell_capacity > capacity and larger.capacity > pair_list.capacity
    np.testing.assert_array_equal(larger.i[: pair_list.capacity], listed.i)
    np.testing.assert_array_equal(larger.j[: pair_list.capacity], listed.j)
    # Too many: flagged, with a cell occupancy beyond the current capacity.
    clusters = room // crowded_per_cluster + 1
    many = clustered_positions(rng, n, clusters, per_cluster, dense - 1)
    flagged = update(many, pair_list)
    assert bool(flagged.overflow)
    assert int(flagged.needed_cell_occupancy) > capacity
    bigger = search.allocate(
        many, minimum=(int(flagged.needed_pairs), int(flagged.needed_cell_occupancy))
    )
    assert not bool(bigger.overflow)
    assert crowd_capacity(n, bigger.cell_capacity, dense) >= clusters * crowded_per_cluster
    assert listed_pairs(bigger, n) == set(brute_force_pairs(many, lengths, 1.0))


def test_a_dilute_box_gets_larger_cells_and_still_lists_every_pair():
    """300 particles in a 6 × 3000 × 6 box: cells of edge r_c = 1 would number
    6 · 3000 · 6 = 108000, 360 per particle. The grid is capped at 4 N = 1200 cells by
    halving the longest axis (3000 → 1500 → 750 → 375 → 187 → 93 → 46 → 23 cells of
    edge ≥ 130), and the list must still be the brute-force pair set. The particles sit
    in three clumps of 100 (one across the periodic boundary along y, one across a cell
    face) so that there are pairs to find."""
    lengths, n = (6.0, 3000.0, 6.0), 300
    box = PeriodicBox(lengths)
    assert cell_grid(box, 1.0) == (6, 3000, 6)
    assert cell_grid(box, 1.0, n) == (6, 23, 6)
    rng = np.random.default_rng(5)
    centres = [2.0, 1500.0, 3000.0 * 8 / 23]  # the last on a face between two cells
    positions = np.concatenate(
        [rng.uniform(-1.5, 1.5, (100, 3)) + np.array([3.0, y, 3.0]) for y in centres]
    ) % np.asarray(lengths)
    search = neighbor_search(box, n, 1.0, 0.0)
    pair_list = search.allocate(jnp.asarray(positions, jnp.float64))
    assert not bool(pair_list.overflow)
    reference = brute_force_pairs(positions, lengths, 1.0)
    assert len(reference) > 1000
    assert listed_pairs(pair_list, n) == set(reference)


def test_a_box_far_larger_than_its_particles_builds_a_small_grid():
    """The scene fuzzer's box of 5.85 × 10⁷ × 5.85 with 600 particles: uncapped, its
    padded cell grid of 2.5·10⁸ cells took more than the fuzzer's 20 s and over 10 GB on
    the host. Capped, it has at most 4 N cells."""
    box = PeriodicBox((5.85, 1e7, 5.85))
    assert np.prod(cell_grid(box, 1.0, 600)) <= 4 * 600
    positions = jnp.asarray(np.random.default_rng(0).uniform(0, 1, (600, 3)) * box.lengths)
    assert not bool(neighbor_search(box, 600, 1.0, 0.0).allocate(positions).overflow)


@pytest.mark.parametrize("count, density, side", [(3000, 3.0, 10), (24000, 3.0, 20), (81, 3.0, 3)])
def test_a_cubic_box_of_a_perfect_cube_volume_has_the_exact_side_and_cell_grid(
    count, density, side
):
    """N/ρ = side³ exactly: the box side is that integer (floating `** (1/3)` gives
    9.999999999999998 for 1000), so a skin-free list at r_c = 1 has `side` cells per
    axis of edge r_c, not side − 1 cells of edge side/(side − 1)."""
    scene = Scene.from_dict(scene_dict(particles={"density": density, "count": count}))
    assert scene.box.lengths == (side, side, side)
    assert cell_grid(PeriodicBox(scene.box.lengths), 1.0) == (side,) * 3


@pytest.mark.parametrize("volume", [2.0, 1000.0 / 3.0, 32000.0, 1e-9, 7.5e6])
def test_the_box_side_is_the_float_nearest_the_cube_root(volume):
    """No neighbouring float's cube is closer to the volume (exact rational
    arithmetic, the definition of correct rounding)."""
    side = cube_root(volume)

    def error(s):
        return abs(Fraction(s) ** 3 - Fraction(volume))

    assert error(side) <= error(np.nextafter(side, 0.0))
    assert error(side) <= error(np.nextafter(side, np.inf))
