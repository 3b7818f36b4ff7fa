"""SRD transport: the collisional stress, the equation of state and the shear viscosity
against Mussawisade et al., J. Chem. Phys. 123, 144905 (2005), eq. 6.

The viscosity is measured at equilibrium from the decay of transverse momentum
fluctuations, C(k, t) ∝ exp(−ν k² t), ν = η/ϱ (jaxdpd.observables.transverse_current):
the slope of ln C over one decay time of the run-mean correlation, jackknife errors
from 10 blocks, ν(k) at the smallest box modes and its straight-line extrapolation
in k² to k = 0 (finite-k error).  These are slow tests (≈ 1–2 % standard errors);
the default run checks the viscosity from the shear stress (tests/test_mpcd_shear.py)
and the estimator on synthetic data (tests/test_transverse_current.py).
"""

import math

import jax
import jax.numpy as jnp
import numpy as np
import pytest
from mpcd_scenes import pure_solvent

from jaxdpd.analysis.statistics import block_average
from jaxdpd.engine import noise
from jaxdpd.engine.build import build
from jaxdpd.geometry.boxes import LeesEdwardsBox, PeriodicBox
from jaxdpd.observables.transverse_current import kinematic_viscosity
from jaxdpd.run import driver
from jaxdpd.scene import Scene
from jaxdpd.solvents.mpcd import transport
from jaxdpd.solvents.mpcd.cells import bin_particles, collision_grid
from jaxdpd.solvents.mpcd.collision import collisional_virial, srd_relative_velocities


def _solvent_scene(
    density, angle, collision_time, length, observables, precision="float64", modes=3
):
    return Scene.from_dict(
        pure_solvent(
            density,
            angle,
            collision_time,
            length,
            precision=precision,
            output={"observables": observables, "current_modes": modes},
        )
    )


def test_eq_6_gives_the_seeds_viscosity():
    """Mussawisade et al. §IV: ρ = 10, α = 150°, λ = h = 0.1 give η = 10 (in units of
    √(m k_BT)/a²), collisional part dominant."""
    alpha = math.radians(150)
    fluid = transport.SRDFluid(10, alpha, 0.1)
    assert abs(fluid.shear_viscosity() - 10) < 0.05
    assert fluid.collisional_viscosity() > 10 * fluid.kinetic_viscosity()
    # γ_α of eq. 9 is 1 at α = 120° (the mean velocity is lost in one collision).
    assert transport.rotation_factor(math.radians(120)) == pytest.approx(1.0)


@pytest.mark.parametrize("box_kind", ["periodic", "lees_edwards"])
def test_collisional_stress_of_a_linear_profile_is_eq_6(box_kind):
    """One collision of an ideal gas (ρ = 3 per cell, Poisson occupancy) in the linear
    flow v = γ̇ y e_x.  In a cell of n particles at uniform in-cell positions ξ,
    E[Δv_i] = −γ_α γ̇ (ξ_iy − ξ̄_y) e_x over random axes (eq. 9), so
    E[Σ_i ξ_iy m Δv_ix] = −m γ_α γ̇ (n − 1) a²/12 per occupied cell, and with
    E[max(n − 1, 0)] = ρ − 1 + e^{−ρ}:

        P^coll_yx = Σ ξ_y m Δv_x /(V h) = −γ̇ m (ρ − 1 + e^{−ρ})(1 − cos α)/(18 a h),

    eq. 6's η_coll with the Poisson factor (eq. 6 writes ρ − 1); P^coll_xy = 0 (the
    SRD collisional stress is not symmetric).  In the periodic box the grid shift is
    kept at 0 along y, so that no cell straddles the velocity jump γ̇ L_y at the
    boundary.  In the Lees–Edwards box (peculiar velocities 0, laboratory velocities
    u = γ̇ (y − L_y/2)) the shift is random along y too and the image offset Δ random:
    cells across the moving boundary must see the continuous profile through the
    images (Kikuchi et al. 2003).  200 configurations × 512 cells; tolerance 4
    standard errors; the Poisson term (2.5 % at ρ = 3) is resolved.
    """
    length, rho, alpha, h, shear_rate = 8, 3.0, math.radians(130), 0.5, 1.0
    lengths = (float(length),) * 3
    grid = collision_grid(lengths, 1.0)
    n = int(rho * length**3)
    rng = np.random.default_rng(11)
    samples = 200
    positions = rng.uniform(0, length, size=(samples, n, 3))
    shifts = rng.uniform(0, 1, size=(samples, 3))
    offsets = rng.uniform(-length / 2, length / 2, size=samples)
    if box_kind == "periodic":
        shifts[:, 1] = 0
    sheared = LeesEdwardsBox(lengths, shear_rate)

    def bound_box(offset):
        if box_kind == "periodic":
            return PeriodicBox(lengths)
        state = sheared.initial_state(jnp.float64)
        return sheared.bind(state.set(offset=offset))

    @jax.jit
    @jax.vmap
    def virial(positions, shift, offset, collision):
        if box_kind == "periodic":
            velocities = jnp.zeros_like(positions).at[:, 0].set(shear_rate * positions[:, 1])
        else:
            velocities = jnp.zeros_like(positions)  # peculiar: on the streaming profile
        binning = bin_particles(grid, bound_box(offset), positions, velocities, shift)
        relative, rotated = srd_relative_velocities(
            binning.frame_velocities,
            None,
            binning.cell,
            grid.n_cells,
            noise.step_key(1, collision),
            math.cos(alpha),
            math.sin(alpha),
        )
        return collisional_virial(binning.local, (rotated - relative).T, None) / (length**3 * h)

    stress = np.asarray(
        virial(
            jnp.asarray(positions), jnp.asarray(shifts), jnp.asarray(offsets), jnp.arange(samples)
        )
    )
    fluid = transport.SRDFluid(rho, alpha, h)
    expected = -shear_rate * fluid.collisional_viscosity(poisson=True)
    for (a, b), target in (((1, 0), expected), ((0, 1), 0.0)):
        values = stress[:, a, b]
        error = values.std(ddof=1) / math.sqrt(samples)
        assert error < 0.006 * abs(expected)
        assert abs(values.mean() - target) < 4 * error, (a, b, values.mean(), target, error)
    shear = stress[:, 1, 0]
    without_poisson = -shear_rate * fluid.collisional_viscosity()
    assert abs(shear.mean() - without_poisson) > 4 * shear.std(ddof=1) / math.sqrt(samples)


def test_equation_of_state_is_the_ideal_gas():
    """SRD with the random shift has the ideal-gas pressure p = ρ k_BT (Ihle & Kroll,
    Phys. Rev. E 67, 066705 (2003)): the collisional part of the pressure tensor
    averages to zero, its shear components too.  The kinetic part stays at ρ k_BT
    exactly (energy is conserved).  Tolerance: 4 standard errors from 20 block
    averages of 2000 collisions."""
    scene = _solvent_scene(5.0, 90.0, 0.5, 6, ["temperature", "pressure"])
    simulation = build(scene)
    state, samples, _ = driver.run_chunk(simulation, simulation.init_fn(), 2000)
    assert set(samples["virial"]) == {"collision"}  # a pure solvent has no other part
    collisional = samples["virial"]["collision"] / scene.volume
    for a, b in ((0, 0), (1, 1), (2, 2), (0, 1), (1, 2)):
        mean, error = block_average(collisional[:, a, b], n_blocks=20)
        assert abs(mean) < 4 * error, (a, b, mean, error)
        assert error < 0.02 * scene.particles.density
    kinetic = np.trace(samples["kinetic"], axis1=1, axis2=2) / (3 * scene.volume)
    np.testing.assert_allclose(kinetic, kinetic[0], rtol=1e-10)


def _measured_viscosity(scene, steps, modes_used, n_blocks=10):
    """ν from the transverse currents of an equilibrium run (first 200 steps dropped)."""
    simulation = build(scene)
    state, _, _ = driver.run_chunk(simulation, simulation.init_fn(), 200)
    chunks = []
    chunk = 2000 if steps >= 2000 else steps
    for _ in range(steps // chunk):
        state, samples, _ = driver.run_chunk(simulation, state, chunk)
        chunks.append(samples["transverse_current"][:, :modes_used])
    currents = np.concatenate(chunks)
    return kinematic_viscosity(
        currents, scene.solvent.collision_time, scene.box.lengths[0], n_blocks=n_blocks
    )


@pytest.mark.slow
@pytest.mark.parametrize(
    ("density", "angle", "collision_time", "length", "modes", "steps"),
    [
        (10.0, 130.0, 0.1, 10, 3, 50_000),
        (10.0, 130.0, 1.0, 16, 2, 50_000),
        (5.0, 90.0, 0.5, 12, 2, 100_000),
    ],
)
def test_viscosity_is_eq_6_within_5_percent(density, angle, collision_time, length, modes, steps):
    """ν = η/ϱ from the transverse currents at the `modes` smallest wave vectors of an
    L³ box, extrapolated linearly in k² to k = 0, within 5 % of eq. 6 (η_kin +
    η_coll).  L is chosen so that k λ ≤ 0.4 at n = 1 (λ = h √(k_BT/m) the mean free
    path; ν(k) falls by ≈ 4 % from k = 0 to k λ = 0.63 at h = 1), and the run so that
    the extrapolated value has a standard error below 2 % (10 blocks), which makes
    the 5 % band a meaningful check.  float32 (statistical errors dominate by far)."""
    scene = _solvent_scene(
        density, angle, collision_time, length, ["transverse_current"], "float32", modes
    )
    result = _measured_viscosity(scene, steps, modes)
    expected = transport.SRDFluid.from_scene(scene).kinematic_viscosity()
    measured, error = result["extrapolated"], result["extrapolated_error"]
    print(
        f"ρ={density} α={angle} h={collision_time} L={length}: ν(k_n)/ν_eq6 = "
        f"{result['per_mode'] / expected} ± {result['per_mode_error'] / expected}; "
        f"k→0: {measured / expected:.4f} ± {error / expected:.4f}"
    )
    assert error < 0.02 * expected
    assert abs(measured - expected) < 0.05 * expected
