"""MPCD collisions: cell binning, the SRD rotation (Mussawisade et al. 2005, eq. 2), the
single-particle rotation of the Rouse variant (§IV.A, eq. 9) and the Maxwell–Boltzmann
scaling thermostat (Huang et al., J. Comput. Phys. 229, 168 (2010)).

References are independent NumPy/SciPy computations of the same formulas; the
conservation laws are checked against round-off bounds stated in each test.
"""

import functools
import math

import jax
import jax.numpy as jnp
import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from jaxdpd.engine import noise
from jaxdpd.geometry.boxes import PeriodicBox
from jaxdpd.solvents.mpcd import transport
from jaxdpd.solvents.mpcd.cells import bin_particles, cell_ids, collision_grid, grid_shift
from jaxdpd.solvents.mpcd.collision import (
    maxwell_boltzmann_scaling,
    random_axes,
    rotate,
    single_particle_rotation,
    srd_collision,
    srd_relative_velocities,
)

GRID = collision_grid((4.0, 5.0, 6.0), 1.0)
BOX = PeriodicBox(GRID.lengths)
ALPHA = math.radians(130.0)


def _fluid(seed, n=1200, heavy=40, heavy_mass=10.0, dtype=np.float64):
    """Random positions in GRID's box, Gaussian velocities with a drift, and masses:
    `heavy` particles of mass `heavy_mass`, the rest of mass 1."""
    rng = np.random.default_rng(seed)
    positions = rng.uniform(size=(n, 3)) * np.asarray(GRID.lengths)
    velocities = rng.normal(size=(n, 3)) + np.array([0.3, -0.2, 0.1])
    masses = np.ones(n)
    masses[:heavy] = heavy_mass
    return positions.astype(dtype), velocities.astype(dtype), masses.astype(dtype)


def _numpy_binning(positions, shift, cell_size, shape):
    """Cell ids and in-cell coordinates by plain NumPy (module docstring of cells)."""
    lengths = np.asarray(shape) * cell_size
    shifted = np.mod(positions - shift, lengths)
    index = np.floor(shifted / cell_size).astype(int) % np.asarray(shape)
    cell = index[:, 0] + shape[0] * (index[:, 1] + shape[1] * index[:, 2])
    return cell, shifted - index * cell_size


def _at_rest(collide):
    """A jitted collision in the box at rest."""
    return jax.jit(functools.partial(collide, BOX))


@functools.partial(jax.jit, static_argnums=1)
def _axes(key, count):
    return random_axes(key, jnp.arange(count, dtype=jnp.uint32), jnp.float64)


def _cell_sums(values, cell, n_cells):
    totals = np.zeros((n_cells,) + values.shape[1:])
    np.add.at(totals, cell, values)
    return totals


def test_grid_shift_and_binning_match_numpy():
    positions, _, _ = _fluid(0)
    shifts = np.asarray(
        jax.vmap(lambda n: grid_shift(noise.step_key(5, n), GRID.cell_size, jnp.float64))(
            jnp.arange(200)
        )
    )
    assert np.all((shifts >= 0) & (shifts < GRID.cell_size))
    # Uniform on [0, a): mean a/2 within 5 standard errors (σ = a/√12).
    assert np.all(np.abs(shifts.mean(axis=0) - 0.5) < 5 / math.sqrt(12 * 200))
    binned = jax.jit(lambda shift: bin_particles(GRID, BOX, jnp.asarray(positions), None, shift))
    for shift in shifts[:5]:
        binning = binned(shift)
        cell, local = _numpy_binning(positions, shift, GRID.cell_size, GRID.shape)
        np.testing.assert_array_equal(binning.cell, cell)
        np.testing.assert_allclose(binning.local, local, atol=1e-12)


def test_cell_ids_fold_the_far_face_into_cell_zero():
    """Round-off can give ⌊ξ/a⌋ = n at ξ = L; that cell index is the periodic image of
    index 0, and every id lies in [0, n_cells)."""
    n_x, n_y, n_z = GRID.shape
    index = jnp.asarray(
        [
            [0, 0, 0],
            [n_x, 0, 0],
            [0, n_y, 0],
            [0, 0, n_z],
            [n_x, n_y, n_z],
            [1, n_y, 2],
            [n_x - 1, n_y - 1, n_z - 1],
        ],
        jnp.float64,
    )
    ids = np.asarray(cell_ids(GRID, index))
    expected = [0, 0, 0, 0, 0, 1 + n_x * n_y * 2, GRID.n_cells - 1]
    np.testing.assert_array_equal(ids, expected)


@pytest.mark.parametrize("dtype", [jnp.float64, jnp.float32])
def test_collision_conserves_mass_momentum_and_energy_of_every_cell(dtype):
    """Eq. 2 conserves each cell's momentum and kinetic energy (rotation of relative
    velocities about the mass-weighted mean).  Round-off bound: every new velocity
    carries a few ε relative error, so a cell sum errs by ≲ 20 ε Σ m|v| (momentum)
    and ≲ 20 ε Σ m v² (energy).  Cells as the code bins them (the binning itself is
    checked against NumPy in float64 above)."""
    positions, velocities, masses = _fluid(1, dtype=np.dtype(dtype))
    collide = srd_collision(GRID, ALPHA, jnp.asarray(masses), None, False, dtype)

    @jax.jit
    def collide_and_bin(key):
        new, _ = collide(BOX, jnp.asarray(positions), jnp.asarray(velocities), key)
        shift = grid_shift(key, GRID.cell_size, dtype)
        return new, bin_particles(GRID, BOX, jnp.asarray(positions), None, shift).cell

    eps = float(jnp.finfo(dtype).eps)
    for collision in range(3):
        new, cell = collide_and_bin(noise.step_key(2, collision))
        assert new.dtype == dtype
        new, cell = np.asarray(new, np.float64), np.asarray(cell)
        assert np.all(np.isfinite(new))
        m, v = masses.astype(np.float64)[:, None], velocities.astype(np.float64)
        scale_p = _cell_sums(m * np.abs(v), cell, GRID.n_cells)
        scale_e = _cell_sums(m * v * v, cell, GRID.n_cells).sum(axis=1)
        momentum_change = _cell_sums(m * (new - v), cell, GRID.n_cells)
        energy_change = _cell_sums(m * (new**2 - v**2), cell, GRID.n_cells).sum(axis=1)
        assert np.all(np.abs(momentum_change) <= 20 * eps * scale_p + 1e-300)
        assert np.all(np.abs(energy_change) <= 20 * eps * scale_e + 1e-300)
        # The collision does change velocities (not a no-op).
        assert np.mean(np.abs(new - v)) > 0.5


def test_collision_is_eq_2_with_the_cells_axis_and_mass_weighted_mean():
    """v_i' = u_c + R(n_c, α)(v_i − u_c), u_c mass-weighted, R from SciPy's rotation
    vector α n_c, n_c the cell's axis (random_axes of the cell id)."""
    positions, velocities, masses = _fluid(3)
    key = noise.step_key(9, 4)
    collide = _at_rest(srd_collision(GRID, ALPHA, jnp.asarray(masses), None, False, jnp.float64))
    new = np.asarray(collide(jnp.asarray(positions), jnp.asarray(velocities), key)[0])
    shift = np.asarray(grid_shift(key, 1.0, jnp.float64))
    cell, _ = _numpy_binning(positions, shift, 1.0, GRID.shape)
    axes = np.asarray(_axes(key, GRID.n_cells))
    mass = _cell_sums(masses, cell, GRID.n_cells)
    mean = (
        _cell_sums(masses[:, None] * velocities, cell, GRID.n_cells) / np.maximum(mass, 1)[:, None]
    )
    rotations = Rotation.from_rotvec(ALPHA * axes[cell])
    expected = mean[cell] + rotations.apply(velocities - mean[cell])
    np.testing.assert_allclose(new, expected, rtol=0, atol=1e-12)


def test_rotate_matches_scipy_and_random_axes_are_isotropic():
    rng = np.random.default_rng(4)
    vectors = rng.normal(size=(500, 3))
    axes = _axes(noise.step_key(1, 1), 500)
    rotated = jax.jit(rotate)(jnp.asarray(vectors).T, axes.T, math.cos(ALPHA), math.sin(ALPHA)).T
    expected = Rotation.from_rotvec(ALPHA * np.asarray(axes)).apply(vectors)
    np.testing.assert_allclose(rotated, expected, atol=1e-13)
    # Uniform on the sphere: <n> = 0 and <n n^T> = I/3; per component σ(n_a) = 1/√3 and
    # σ(n_a²) = 2/(3√5), σ(n_a n_b) = 1/√15; 5 standard errors.
    n = 100_000
    many = np.asarray(_axes(noise.step_key(2, 2), n))
    np.testing.assert_allclose(np.linalg.norm(many, axis=1), 1.0, atol=1e-14)
    assert np.all(np.abs(many.mean(axis=0)) < 5 / math.sqrt(3 * n))
    second = many.T @ many / n
    assert np.all(np.abs(np.diag(second) - 1 / 3) < 5 * 2 / (3 * math.sqrt(5 * n)))
    assert np.all(np.abs(second[np.triu_indices(3, 1)]) < 5 / math.sqrt(15 * n))


def test_lone_particles_keep_their_velocity_and_empty_cells_make_no_nan():
    """A particle alone in its cell has v − u_c = 0: eq. 2 leaves it as it is.  Here 5
    particles sit in a 4×5×6 grid (almost every cell empty), one per cell."""
    positions = np.array(
        [[0.5, 0.5, 0.5], [2.5, 0.5, 0.5], [0.5, 2.5, 0.5], [0.5, 0.5, 2.5], [2.5, 2.5, 4.5]]
    )
    velocities = np.random.default_rng(5).normal(size=(5, 3)) * 3
    collide = _at_rest(srd_collision(GRID, ALPHA, jnp.full(5, 7.0), None, True, jnp.float64))
    for collision in range(20):
        new, virial = collide(
            jnp.asarray(positions), jnp.asarray(velocities), noise.step_key(0, collision)
        )
        # u_c = (m v)/m may differ from v by an ulp; bound 8 ε max|v|.
        np.testing.assert_allclose(new, velocities, rtol=0, atol=8 * 2.2e-16 * 3 * 5)
        assert np.all(np.isfinite(virial))


def test_collision_is_galilean_invariant_and_independent_of_particle_order():
    """Adding U to every velocity adds U to every result (eq. 2 acts on v − u_c);
    permuting the particles permutes the result (axes are drawn per cell id), both to
    round-off (the cell sums are summed in another order)."""
    positions, velocities, masses = _fluid(6)
    collide = _at_rest(srd_collision(GRID, ALPHA, jnp.asarray(masses), None, False, jnp.float64))
    key = noise.step_key(3, 17)
    base = np.asarray(collide(jnp.asarray(positions), jnp.asarray(velocities), key)[0])
    drift = np.array([2.0, -1.5, 0.7])
    moved = np.asarray(collide(jnp.asarray(positions), jnp.asarray(velocities + drift), key)[0])
    np.testing.assert_allclose(moved - drift, base, atol=1e-13)
    order = np.random.default_rng(7).permutation(len(masses))
    permuted_collide = _at_rest(
        srd_collision(GRID, ALPHA, jnp.asarray(masses[order]), None, False, jnp.float64)
    )
    permuted = np.asarray(
        permuted_collide(jnp.asarray(positions[order]), jnp.asarray(velocities[order]), key)[0]
    )
    np.testing.assert_allclose(permuted, base[order], atol=1e-13)


def test_single_particle_rotation_keeps_speeds_and_decays_by_one_minus_gamma_alpha():
    """Rouse variant: |v'| = |v|, and over random axes E[v'] = (1 − γ_α) v with
    γ_α = (2/3)(1 − cos α) (eq. 9).  200 000 rotations of one velocity; the component
    standard error from the sample spread, 5 standard errors."""
    n = 200_000
    velocity = np.array([1.0, -0.5, 2.0])
    rotated = np.asarray(
        jax.jit(single_particle_rotation)(
            jnp.tile(jnp.asarray(velocity), (n, 1)),
            noise.step_key(4, 0),
            math.cos(ALPHA),
            math.sin(ALPHA),
        )
    )
    np.testing.assert_allclose(
        np.linalg.norm(rotated, axis=1), np.linalg.norm(velocity), rtol=1e-14
    )
    mean = rotated.mean(axis=0)
    error = rotated.std(axis=0) / math.sqrt(n)
    expected = (1 - transport.rotation_factor(ALPHA)) * velocity
    assert np.all(np.abs(mean - expected) < 5 * error), (mean, expected, error)


def test_maxwell_boltzmann_scaling_draws_the_canonical_cell_kinetic_energy():
    """MBS (Huang et al. 2010): the relative kinetic energy of a cell of N_c particles
    is redrawn from P(E) ∝ E^{f/2−1} e^{−E/kT}, f = 3(N_c − 1), so E/kT has mean and
    variance f/2 (Gamma law), whatever it was before; directions and each cell's
    momentum are kept.  A hot fluid (relative velocities ×3) is scaled by 400
    collision keys; per cell the mean and variance of E/kT are compared with f/2
    within 5 standard errors (σ of the mean: √(f/2/400); of the variance: from the
    Gamma law's fourth moment, √((κ₄ + 2 κ₂²)/400) with κ₂ = f/2, κ₄ = 3f)."""
    positions, velocities, masses = _fluid(8, n=600, heavy=20)
    kT = 1.5
    binning = bin_particles(
        GRID, BOX, jnp.asarray(positions), jnp.asarray(velocities), jnp.zeros(3)
    )
    cell = np.asarray(binning.cell)
    relative, _ = srd_relative_velocities(
        binning.frame_velocities,
        jnp.asarray(masses),
        binning.cell,
        GRID.n_cells,
        noise.step_key(0, 0),
        1.0,
        0.0,
    )
    hot = 3 * relative.T

    @jax.jit
    def energies(key):
        scaled = maxwell_boltzmann_scaling(
            hot, jnp.asarray(masses), binning.cell, GRID.n_cells, key, kT
        )
        return scaled, jax.ops.segment_sum(
            0.5 * jnp.asarray(masses) * jnp.sum(scaled**2, 1), binning.cell, GRID.n_cells
        )

    draws = 400
    samples = (
        np.asarray(jax.vmap(lambda k: energies(noise.step_key(1, k))[1])(jnp.arange(draws))) / kT
    )
    counts = np.bincount(cell, minlength=GRID.n_cells)
    for c in np.nonzero(counts >= 2)[0]:
        half_f = 1.5 * (counts[c] - 1)
        assert abs(samples[:, c].mean() - half_f) < 5 * math.sqrt(half_f / draws)
        variance_error = math.sqrt((6 * half_f + 2 * half_f**2) / draws)
        assert abs(samples[:, c].var(ddof=1) - half_f) < 5 * variance_error
    scaled = np.asarray(energies(noise.step_key(1, 0))[0])
    momentum = _cell_sums(masses[:, None] * scaled, cell, GRID.n_cells)
    np.testing.assert_allclose(momentum, 0, atol=1e-12)
    # Directions kept: the scaled relative velocity is parallel to the hot one.
    cross = np.cross(scaled, np.asarray(hot))
    np.testing.assert_allclose(cross, 0, atol=1e-11)
    # A lone particle (f = 0) is untouched: its relative velocity is zero anyway.
    lone = counts[cell] == 1
    np.testing.assert_array_equal(scaled[lone], np.asarray(hot)[lone])
