"""The lattice-Boltzmann fluid under a Lees–Edwards boundary
(jaxdpd.solvents.lattice_boltzmann.lees_edwards): the translation of the arriving
layers, laminar steady and oscillatory shear against the Navier–Stokes solutions, the
beads' Lees–Edwards images, and (slow) the fluctuating fluid in the sheared frame."""

import functools

import jax.numpy as jnp
import numpy as np
import pytest

from jaxdpd.analysis.statistics import block_average
from jaxdpd.geometry.boxes import LeesEdwardsBox
from jaxdpd.solvents.lattice_boltzmann import lees_edwards
from jaxdpd.solvents.lattice_boltzmann.coupling import interpolate
from jaxdpd.solvents.lattice_boltzmann.fluid import (
    FluidParameters,
    modes,
    thermal_deviations,
)
from jaxdpd.solvents.lattice_boltzmann.lattice import VELOCITIES


def test_translating_a_layer_moves_every_wave_and_keeps_sums_and_squares():
    """Fourier shift theorem: a layer of waves sampled at x_i, translated by s nodes,
    equals the waves sampled at x_i + s (every wave below the Nyquist wave exactly);
    the map is orthogonal, so the layer's sum (mass, momentum) and sum of squares
    (fluctuations) are kept to round-off, also for an even n_x with its Nyquist wave."""
    for n in (7, 8):
        x = np.arange(n)[:, None]
        waves = [1.0 + 0 * x, np.cos(2 * np.pi * x / n + 0.3), np.sin(4 * np.pi * x / n)]
        layer = jnp.asarray(np.concatenate(waves, axis=1)[None], jnp.float64)  # (1, n, 3)
        for shift in (0.37, -2.6, 5.5):
            moved = np.asarray(lees_edwards.translate_layer(layer, jnp.asarray(shift)))
            expected = [
                1.0 + 0 * x,
                np.cos(2 * np.pi * (x + shift) / n + 0.3),
                np.sin(4 * np.pi * (x + shift) / n),
            ]
            np.testing.assert_allclose(moved[0], np.concatenate(expected, axis=1), atol=1e-13)
        noise = jnp.asarray(np.random.default_rng(n).standard_normal((5, n, 4)))
        moved = np.asarray(lees_edwards.translate_layer(noise, jnp.asarray(0.43)))
        np.testing.assert_allclose(moved.sum(axis=1), np.asarray(noise).sum(axis=1), atol=1e-13)
        np.testing.assert_allclose((moved**2).sum(), (np.asarray(noise) ** 2).sum(), rtol=1e-13)


def _density_and_velocity(f, density, velocity):
    return density, velocity


@functools.cache
def _sheared_runner(fluid: FluidParameters, box: LeesEdwardsBox, dtype, steps: int):
    """Jitted: deviations → (final deviations, per-step (ρ, u) of every node) over
    `steps` LB steps of a sheared lattice (lees_edwards.fluid_run)."""
    return lees_edwards.fluid_run(fluid, box, dtype, steps, _density_and_velocity, seed=7)


def _momentum_flux(deviations, fluid: FluidParameters) -> np.ndarray:
    """x-momentum per area and time crossing each interior plane y_j + a/2 upwards
    (n_y − 1,), counted from the populations that just streamed across it:
    Σ_{c_y=+1} c_x f_i(y_{j+1}) − Σ_{c_y=−1} c_x f_i(y_j), times a²/τ², averaged over
    the plane (the rest state carries none)."""
    f = np.asarray(deviations, np.float64)
    c_x = VELOCITIES[:, 0].astype(float)
    up = np.einsum("i,ixyz->y", c_x[lees_edwards.UP], f[lees_edwards.UP])
    down = np.einsum("i,ixyz->y", c_x[lees_edwards.DOWN], f[lees_edwards.DOWN])
    per_node = (up[1:] - down[:-1]) / (fluid.nodes[0] * fluid.nodes[2])
    return per_node * fluid.grid_spacing**2 / fluid.time_step**2


def test_steady_shear_is_linear_without_a_kink_and_has_the_set_viscosity():
    """Plane Couette flow driven by the boundary alone (Wagner & Pagonabarraga 2002):
    from rest, the fluid relaxes to u_x = γ̇ (y − L_y/2) at every layer y_j = (j + ½)a,
    the velocity across the sheared boundary continuing the line (u(y_0) + γ̇ L_y −
    u(y_{n−1}) = γ̇ a), at uniform density, and the x-momentum flux through every plane
    is −ρν γ̇ (Newton's law with the set viscosity).  For a linear profile the
    Chapman–Enskog expansion of the lattice is exact (no higher gradients; the cubic
    lattice error ∂(ρ u_α u_β u_γ) vanishes with u_y = 0), so the only error left is
    the start-up transient, e^{−ν k² t} < 1e-20 after 800 steps (k = 2π/L_y), and
    round-off: tolerances 1e-10 relative.  The offset grows by 0.04 nodes per step,
    so the arriving layers are translated by fractions of a node."""
    fluid = FluidParameters((4, 8, 4), 1.0, 1.0, 1.0, 0.1, 0.3, 0.0)
    shear_rate = 0.005
    box = LeesEdwardsBox((4.0, 8.0, 4.0), shear_rate)
    deviations = jnp.zeros((19, *fluid.nodes), jnp.float64)
    final, (density, velocity) = _sheared_runner(fluid, box, jnp.float64, 800)(deviations)
    heights = np.arange(8) + 0.5 - 4.0
    scale = shear_rate * 8.0
    u = np.asarray(velocity[-1])
    laminar = shear_rate * heights[None, :, None] + 0 * u[0]
    np.testing.assert_allclose(u[0], laminar, atol=1e-10 * scale)
    np.testing.assert_allclose(u[1:], 0, atol=1e-10 * scale)
    np.testing.assert_allclose(np.asarray(density[-1]), fluid.density, rtol=1e-12)
    profile = u[0].mean(axis=(0, 2))
    step_across = profile[0] + shear_rate * 8.0 - profile[-1]
    assert abs(step_across - shear_rate) < 1e-10 * scale
    flux = _momentum_flux(final, fluid)
    viscous = -fluid.density * fluid.kinematic_viscosity * shear_rate
    np.testing.assert_allclose(flux, viscous, rtol=1e-10)


def test_oscillatory_shear_matches_the_stokes_layers_of_the_lees_edwards_box():
    """γ̇(t) = γ̇₀ cos ωt in a Lees–Edwards box: the unsteady Stokes equation
    ∂_t u = ν ∂_y² u with u(y + L) = u(y) + γ̇ L and ∂_y u periodic has the periodic
    solution u = Re[γ̇₀ e^{iωt} L sinh(q (y − L/2)) / (2 sinh(q L/2))], q² = iω/ν
    (Stokes' second problem in a periodic cell).  At |q| L = 3 the profile bends far
    from a line; the lattice solves the diffusion equation to second order, so its
    error is O((|q| a)²) ≈ 3.5 % of the amplitude γ̇₀ L/2 (the time step adds
    O((ωτ)²) ≈ 1e-5): tolerance (|q| a)² γ̇₀ L/2 over the last period, sampled
    every 50 steps.  A wrong phase or sign of the boundary's velocity would miss by
    the whole amplitude."""
    n_y, nu = 16, 0.1
    fluid = FluidParameters((4, n_y, 4), 1.0, 1.0, 1.0, nu, 0.3, 0.0)
    q_abs = 3.0 / n_y
    omega = nu * q_abs**2
    period = int(round(2 * np.pi / omega))
    amplitude = 0.002
    box = LeesEdwardsBox((4.0, float(n_y), 4.0), amplitude, omega)
    deviations = jnp.zeros((19, *fluid.nodes), jnp.float64)
    steps = 2 * period
    _, (_, velocity) = _sheared_runner(fluid, box, jnp.float64, steps)(deviations)
    profiles = np.asarray(velocity[:, 0]).mean(axis=(1, 3))  # (steps, n_y)
    q = np.sqrt(1j * omega / nu)
    y = np.arange(n_y) + 0.5
    shape = n_y * np.sinh(q * (y - n_y / 2)) / (2 * np.sinh(q * n_y / 2))
    samples = np.arange(steps - period, steps, 50)
    times = (samples + 1) * fluid.time_step
    exact = np.real(amplitude * np.exp(1j * omega * times)[:, None] * shape[None])
    error = np.abs(profiles[samples] - exact).max()
    assert np.abs(shape - (y - n_y / 2)).max() > 0.1 * n_y / 2  # not a line
    assert error < q_abs**2 * amplitude * n_y / 2, (error, q_abs**2 * amplitude * n_y / 2)


def test_beads_read_and_feed_the_image_layer_across_the_sheared_boundary():
    """A field continuous across the Lees–Edwards boundary, φ(x, y) = sin(k (x − Δ y/L_y)),
    φ(x + Δ, y + L_y) = φ(x, y), sampled at the node layers y_j = (j + ½) a, is read at
    beads anywhere in the box (many straddling the boundary) with the error of
    linear interpolation, at most (a²/8)(|∂_x²φ| + |∂_y²φ|) ≤ (k a)²/8 (1 + (Δ/L_y)²)
    (each axis interpolated linearly; the Taylor remainder).  A stencil that ignored
    the offset would miss by |φ(x − Δ) − φ(x)| ~ 1 there.  The weights sum to 1, so
    the impulses spread with them add up to what the beads gave (momentum)."""
    lengths, a = (16.0, 8.0, 4.0), 1.0
    nodes = (16, 8, 4)
    offset = 4.3
    k = 2 * np.pi / lengths[0]
    bound = LeesEdwardsBox(lengths, 0.01).bind(
        LeesEdwardsBox(lengths, 0.01).initial_state(jnp.float64).set(offset=jnp.asarray(offset))
    )
    x, y = np.meshgrid(np.arange(16) * a, (np.arange(8) + 0.5) * a, indexing="ij")
    phi = np.sin(k * (x - offset * y / lengths[1]))
    field = np.zeros((3, *nodes))
    field[0] = phi[:, :, None]
    rng = np.random.default_rng(3)
    beads = rng.random((400, 3)) * np.asarray(lengths)
    beads[:100, 1] = rng.random(100) * 0.5 * a  # below the first layer
    beads[100:200, 1] = lengths[1] - rng.random(100) * 0.5 * a  # above the last layer
    stencil = lees_edwards.image_stencil(jnp.asarray(beads), bound, a, nodes)
    read = np.asarray(interpolate(jnp.asarray(field), stencil))[:, 0]
    exact = np.sin(k * (beads[:, 0] - offset * beads[:, 1] / lengths[1]))
    bound_error = (k * a) ** 2 / 8 * (1 + (offset / lengths[1]) ** 2)
    assert np.abs(read - exact).max() < bound_error, (np.abs(read - exact).max(), bound_error)
    np.testing.assert_allclose(np.asarray(stencil.weights).sum(axis=1), 1, rtol=1e-14)
    unsheared = np.sin(k * beads[:100, 0]) - np.sin(k * (beads[:100, 0] - offset))
    assert np.abs(unsheared).max() > 10 * bound_error  # the test can tell


def _fluctuations(f, density, velocity, laminar):
    """Per-step observables of the fluctuating sheared fluid: the node mean of m_k² of
    the modes about the laminar state (19,), per layer the mean density (n_y,), u_x
    (n_y,) and the mean of the momentum modes' squares about the laminar state
    (n_y,), and the x-momentum flux through the interior planes (n_y − 1,), lattice
    units (a = τ = 1)."""
    m = modes(f - laminar)
    c_x = jnp.asarray(VELOCITIES[:, 0], f.dtype)
    up = jnp.einsum("i,ixyz->y", c_x[lees_edwards.UP], f[lees_edwards.UP])
    down = jnp.einsum("i,ixyz->y", c_x[lees_edwards.DOWN], f[lees_edwards.DOWN])
    return (
        jnp.mean(m.reshape(19, -1) ** 2, axis=1),
        density.mean(axis=(0, 2)),
        velocity[0].mean(axis=(0, 2)),
        jnp.mean(jnp.sum(m[1:4] ** 2, axis=0), axis=(0, 2)) / 3,
        (up[1:] - down[:-1]) / (f.shape[1] * f.shape[3]),
    )


@pytest.mark.slow
def test_fluctuating_fluid_in_steady_shear_keeps_equipartition_and_its_viscosity():
    """The fluctuating lattice in steady shear, seen in the sheared frame (about the
    laminar state of the same boundary without noise, run to steady state first):

    - every mode k has variance μ b_k (Dünweg, Schiller & Ladd, Phys. Rev. E 76,
      036704 (2007), §IV; conserved modes × (1 − 1/N_nodes)), as at rest
      (test_lattice_boltzmann_fluid.test_fluid_modes_obey_equipartition);
    - every layer, those at the sheared boundary included, has the momentum
      variance μ/3 of that temperature, the mean density ρ₀ and the mean velocity
      γ̇ (y_j − L_y/2): uniform temperature and density, a linear profile;
    - the mean x-momentum flux through the interior planes is −ρν γ̇ (the set
      viscosity).

    8³ nodes, ν = 0.1, thermal Mach number² 3e-4 as at rest, γ̇ L_y/2 = 0.02 a/τ (the
    lattice's O(u²/c_s²) = 1e-3 departure from Galilean invariance is below the
    resolution); 6000 steps after 100, 20 time blocks (block_average).  Each check
    within 4 standard errors; the mode variances resolved to < 1 %."""
    nodes = (8, 8, 8)
    shear_rate = 0.005
    box = LeesEdwardsBox((8.0, 8.0, 8.0), shear_rate)
    quiet = FluidParameters(nodes, 1.0, 1.0, 1.0, 0.1, 0.3, 0.0)
    laminar, _ = _sheared_runner(quiet, box, jnp.float64, 1500)(
        jnp.zeros((19, *nodes), jnp.float64)
    )
    fluid = FluidParameters(nodes, 1.0, 1.0, 1.0, 0.1, 0.3, 1e-4)
    thermal = thermal_deviations(fluid, np.random.default_rng(9), np.float64)
    steps, skip = 6100, 100
    run = lees_edwards.fluid_run(fluid, box, jnp.float64, steps, _fluctuations, seed=7)
    _, series = run(laminar + thermal, laminar)
    mode_sq, density, velocity_x, momentum_sq, flux = (
        np.asarray(x, np.float64)[skip:] for x in series
    )

    def within(series, expected, label, resolution=None):
        mean, error = block_average(series, n_blocks=20)
        mean, error = np.asarray(mean), np.asarray(error)
        assert np.all(np.abs(mean - expected) < 4 * error), (label, mean, expected, error)
        if resolution is not None:
            assert np.all(error < resolution * np.abs(expected)), (label, error)

    expected = fluid.mode_variances.copy()
    expected[:4] *= 1 - 1 / fluid.n_nodes
    within(mode_sq, expected, "mode variances", resolution=0.01)
    within(momentum_sq, fluid.mode_variances[1] * (1 - 1 / fluid.n_nodes), "layer temperature")
    within(density, fluid.density, "layer density")
    heights = np.arange(8) + 0.5 - 4.0
    within(velocity_x, shear_rate * heights, "velocity profile")
    viscous = -fluid.density * fluid.kinematic_viscosity * shear_rate
    within(flux.mean(axis=1), viscous, "momentum flux", resolution=0.05)
