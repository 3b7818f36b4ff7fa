"""Lees–Edwards geometry: separations, neighbour sets and wrapping across the moving
boundary (thesis §3.3.1, eqs. 3.18–3.19).

Reference: a brute-force search over the periodic images of the sheared lattice,
r_j + n_x a1 + n_y a2 + n_z a3 with a1 = (L_x, 0, 0), a2 = (Δ, L_y, 0),
a3 = (0, 0, L_z), |n_x| ≤ 2, |n_y|, |n_z| ≤ 1: the shortest image vector of every pair.
"""

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from jaxdpd.forces.pair_sums import pair_geometry
from jaxdpd.geometry.boxes import LeesEdwardsBox
from jaxdpd.geometry.neighbors.cell_list import cell_list_search

LENGTHS = (7.0, 6.0, 5.0)  # L_x ≠ L_y: the tilt reaches L_x/(2 L_y) = 0.58
CUTOFF = 1.0
N = 420


def brute_force_pairs(positions, lengths, offset, cutoff):
    """{(i, j): shortest image vector r_i − r_j} for pairs closer than the cut-off."""
    lx, ly, lz = lengths
    shifts = np.array(
        [
            (nx * lx + ny * offset, ny * ly, nz * lz)
            for nx in range(-2, 3)
            for ny in (-1, 0, 1)
            for nz in (-1, 0, 1)
        ]
    )
    pairs = {}
    i, j = np.triu_indices(len(positions), 1)
    raw = positions[i] - positions[j]
    images = raw[:, None, :] - shifts[None]
    lengths_sq = np.sum(images**2, axis=-1)
    best = np.argmin(lengths_sq, axis=1)
    vectors = images[np.arange(len(i)), best]
    close = np.sqrt(lengths_sq[np.arange(len(i)), best]) < cutoff
    for a, b, vector in zip(i[close], j[close], vectors[close], strict=True):
        pairs[(int(a), int(b))] = vector
    return pairs


def listed_pairs(box, search, positions, box_state):
    """{(i, j): separation} of the cell list's pairs within the cut-off."""
    pair_list = search.allocate(positions, 1.5, box_state=box_state)
    assert not bool(pair_list.overflow)
    geometry = pair_geometry(box.bind(box_state), positions, pair_list, CUTOFF, half=True)
    within = np.asarray(geometry.within)
    i, j = np.asarray(geometry.i)[within], np.asarray(geometry.j)[within]
    vectors = np.stack([np.asarray(s)[within] for s in geometry.separation], axis=1)
    pairs = {}
    for a, b, vector in zip(i, j, vectors, strict=True):
        key, sign = ((int(a), int(b)), 1) if a < b else ((int(b), int(a)), -1)
        assert key not in pairs, f"pair {key} listed twice"
        pairs[key] = sign * vector
    return pairs


def box_state(box, offset, dtype=jnp.float64):
    return box.initial_state(dtype).set(offset=jnp.asarray(offset, dtype))


@pytest.fixture(scope="module")
def sheared():
    box = LeesEdwardsBox(LENGTHS, shear_rate=0.5)
    return box, cell_list_search(box, N, CUTOFF, 0.0)


@pytest.mark.parametrize(
    "offset_fraction", [-0.5, -0.5 + 1e-9, -0.31, 0.0, 0.17, 0.4999, 0.5 - 1e-9]
)
def test_pairs_across_the_moving_boundary_match_brute_force(sheared, offset_fraction):
    """Same neighbour set (each pair once) and the same separation vectors as the
    image search, at offsets across [−L_x/2, L_x/2) including both edges."""
    box, search = sheared
    offset = offset_fraction * LENGTHS[0]
    positions = np.random.default_rng(3).uniform(size=(N, 3)) * np.asarray(LENGTHS)
    found = listed_pairs(box, search, jnp.asarray(positions), box_state(box, offset))
    expected = brute_force_pairs(positions, LENGTHS, offset, CUTOFF)
    assert set(found) == set(expected)
    for key, vector in expected.items():
        np.testing.assert_allclose(found[key], vector, atol=1e-12)
    crossing = [k for k, v in expected.items() if abs(positions[k[0], 1] - positions[k[1], 1]) > 3]
    assert len(crossing) > 10  # the boundary really was crossed


def test_offset_after_a_million_strain_units_in_float32(sheared):
    """γ̇ = 1, Δt = 0.04 for 2.5e7 steps (strain 1e6) in float32: the offset is
    advanced modulo L_x every step, so it stays in [−L_x/2, L_x/2) with float32
    resolution there, and pairs measured at it still match the image search
    (float32 round-off of coordinates below 10: tolerance 1e-5)."""
    box = LeesEdwardsBox(LENGTHS, shear_rate=1.0)
    steps, dt = 25_000_000, 0.04

    @jax.jit
    def strain(state):
        return jax.lax.fori_loop(0, steps, lambda _, s: box.advance(s, 0.0, dt), state)

    state = strain(box.initial_state(jnp.float32))
    offset = float(state.offset)
    assert -LENGTHS[0] / 2 <= offset < LENGTHS[0] / 2
    assert state.offset.dtype == jnp.float32
    # The strain really accumulated: Δ = L_y γ̇ t mod L_x (L_y γ̇ t = 6e6), up to the
    # rounding of each addition, at most half an ulp of |Δ| < 4 (1.2e-7) per step:
    # 3.0 in all, a relative 5e-7 of the sheared distance.  (A float32 strain counter
    # could not even resolve one step's strain 0.04 at strain 1e6, its ulp 0.06.)
    increment = np.float64(np.float32(np.float32(LENGTHS[1]) * np.float32(dt)))
    exact = (increment * steps + LENGTHS[0] / 2) % LENGTHS[0] - LENGTHS[0] / 2
    bound = steps * 0.5 * np.spacing(np.float32(3.9))
    assert abs((offset - exact + LENGTHS[0] / 2) % LENGTHS[0] - LENGTHS[0] / 2) < bound
    search = cell_list_search(box, N, CUTOFF, 0.0)
    positions = np.random.default_rng(4).uniform(size=(N, 3)) * np.asarray(LENGTHS)
    found = listed_pairs(box, search, jnp.asarray(positions, jnp.float32), state)
    expected = brute_force_pairs(positions, LENGTHS, offset, CUTOFF)
    # Pairs within float32 round-off of the cut-off may fall on either side.
    boundary = {k for k, v in expected.items() if np.linalg.norm(v) > CUTOFF - 1e-5}
    assert set(found) - boundary == set(expected) - boundary
    for key in set(expected) - boundary:
        np.testing.assert_allclose(found[key], expected[key], atol=1e-5)


def test_crossing_the_sheared_face_shifts_x_by_the_offset():
    """A particle leaving through y = L_y re-enters at y − L_y, x − Δ (wrapped), and
    one leaving through y = 0 at x + Δ; image counters count the faces crossed;
    a coordinate that rounds to exactly L is folded to 0 and counted."""
    box = LeesEdwardsBox(LENGTHS, shear_rate=0.5)
    bound = box.bind(box_state(box, 2.5))
    moved = jnp.asarray([[1.0, 6.2, 1.0], [6.5, -0.1, 4.0], [3.0, 3.0, -1e-300]])
    wrapped, image = bound.wrap(moved, jnp.zeros((3, 3), jnp.int32))
    np.testing.assert_allclose(wrapped[0], [1.0 - 2.5 + 7.0, 0.2, 1.0], atol=1e-12)
    np.testing.assert_allclose(wrapped[1], [6.5 + 2.5 - 7.0, 5.9, 4.0], atol=1e-12)
    np.testing.assert_array_equal(image[:2], [[-1, 1, 0], [1, -1, 0]])
    # −1e-300 + L_z rounds to L_z: the particle is at z = 0 in the primary box.
    assert float(wrapped[2, 2]) == 0.0 and int(image[2, 2]) == 0


def test_dpd_forces_across_the_moving_boundary_use_laboratory_velocities():
    """Groot–Warren forces in a sheared box against a brute-force sum over the
    images of the sheared lattice in the laboratory frame (thesis eqs. 2.4–2.9 with
    eq. 3.18): the image n_y a2 of particle j moves with v_j + n_y γ̇ L_y x̂, and
    v = c + γ̇ (y − L_y/2) x̂.  With λ = 0 the forces of step 1 are evaluated at the
    positions of step 1 with the velocities of step 0, both known here."""
    from conftest import make_scene

    from jaxdpd.engine import noise
    from jaxdpd.engine.build import build
    from jaxdpd.run import driver

    shear_rate, gamma, a = 0.7, 4.5, 25.0
    scene = make_scene(
        particles={"density": 3.0, "count": 300},
        integrator={"dt": 0.04, "lambda": 0.0},
        flow={"kind": "shear", "shear_rate": shear_rate},
    )
    simulation = build(scene)
    start = simulation.init_fn()
    # Start from a large offset so that the moving boundary matters.
    start = start.set(box_state=start.box_state.set(offset=jnp.asarray(1.3)))
    after = driver.run(simulation, start, 1, 1)
    lengths = np.asarray(scene.box.lengths)
    positions = np.asarray(after.positions)
    velocities = np.asarray(start.velocities)
    offset = float(after.box_state.offset)
    lab = velocities.copy()
    lab[:, 0] += shear_rate * (positions[:, 1] - lengths[1] / 2)

    forces = np.zeros_like(positions)
    key = noise.step_key(scene.seed, 1)
    for nx in range(-2, 3):
        for ny in (-1, 0, 1):
            for nz in (-1, 0, 1):
                shift = np.array([nx * lengths[0] + ny * offset, ny * lengths[1], nz * lengths[2]])
                d = positions[:, None, :] - (positions[None, :, :] + shift)
                r = np.linalg.norm(d, axis=-1)
                close = (r < 1.0) & (r > 0)
                i, j = np.nonzero(close)
                e = d[i, j] / r[i, j, None]
                w = 1 - r[i, j]
                v_image = lab[j] + np.array([ny * shear_rate * lengths[1], 0.0, 0.0])
                normal_velocity = np.sum(e * (lab[i] - v_image), axis=1)
                theta = np.asarray(
                    noise.pair_uniform_unit_variance(
                        key, jnp.asarray(i), jnp.asarray(j), jnp.float64
                    )
                )
                magnitude = (
                    a * w
                    - gamma * w * w * normal_velocity
                    + np.sqrt(2 * gamma) * w * theta / np.sqrt(0.04)
                )
                np.add.at(forces, i, magnitude[:, None] * e)
    np.testing.assert_allclose(np.asarray(after.forces), forces, atol=1e-9)


def test_radial_distribution_in_a_sheared_box_counts_image_search_distances(sheared):
    """g(r)'s pair histogram at a large offset equals the histogram of the
    brute-force shortest image distances."""
    from jaxdpd.observables.rdf import RadialDistribution

    box, _ = sheared
    state = box_state(box, 0.45 * LENGTHS[0])
    positions = np.random.default_rng(5).uniform(size=(N, 3)) * np.asarray(LENGTHS)
    rdf = RadialDistribution(box, N, 2.0, 20)
    rdf.sample(jnp.asarray(positions), state)
    distances = [
        np.linalg.norm(v) for v in brute_force_pairs(positions, LENGTHS, 0.45 * 7.0, 2.0).values()
    ]
    expected, _ = np.histogram(distances, bins=20, range=(0.0, 2.0))
    np.testing.assert_array_equal(rdf.counts, expected)
