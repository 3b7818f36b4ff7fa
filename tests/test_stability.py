"""Hard cases that must stay numerically stable, and failures that must be named.

The suite of issue 12.  Each case either runs stably (finite, at its set
temperature, invariants kept) or, where the physics makes the run impossible, stops
with a named error (a flag turned into a `SimulationError` whose message says what
to change) instead of NaN or silent drift.  Cases tested here:

- Lees–Edwards shear after 10⁶ strain units in float32 (run-level; the pair geometry
  at that offset is in tests/test_lees_edwards_geometry.py);
- the clock of an oscillatory shear over 2·10⁶ steps;
- FENE dumbbells in a DPD solvent under strong shear, and soft ones with a time step
  too large for the springs (named error);
- Brownian FENE dumbbells at high Deborah number in shear and planar elongation;
- MPCD with most collision cells empty;
- pathwise derivatives through 10⁴ steps (a warning naming the fluctuation
  estimator), checked against finite differences over a short run.

Cases tested next to their method (same fixtures):
- Lowe–Andersen at ΓΔt = 1: tests/test_lowe_andersen_fluid.py
  (`test_temperature_within_half_percent_at_unit_collision_probability`);
- a time step far too large: tests/test_driver.py
  (`test_a_time_step_far_too_large_stops_with_a_message_and_a_checkpoint`);
- a FENE spring at Q ≥ Q0 at rest: tests/test_polymer_scene.py;
- MPCD cells holding zero or one particle: tests/test_mpcd_collision.py;
- a lattice-Boltzmann fluid driven past its Mach limit: tests/test_lattice_boltzmann_coupling.py.

Tolerances are four standard errors of block averages (combined in quadrature for
differences) unless a test states another bound.
"""

import math

import jax
import jax.numpy as jnp
import numpy as np
import pytest
from conftest import make_scene

from jaxdpd import brownian as bd
from jaxdpd.analysis.statistics import block_average
from jaxdpd.engine import errors
from jaxdpd.engine.build import build
from jaxdpd.engine.parameters import with_parameters
from jaxdpd.geometry.boxes.lees_edwards import LeesEdwardsBox
from jaxdpd.run import driver
from jaxdpd.studies.pathwise import (
    MAX_TANGENT_GROWTH,
    PathwiseDerivativeWarning,
    pathwise_derivative,
)

MILLION_STRAIN = 1.0e6


def _series(simulation, state, steps, chunk):
    parts = {}

    def keep(result):
        for name, values in result.series.items():
            parts.setdefault(name, []).append(np.asarray(values, np.float64))

    state = driver.run(simulation, state, steps, chunk, on_chunk=keep)
    return state, {name: np.concatenate(values) for name, values in parts.items()}


def test_shear_after_a_million_strain_units_in_float32_matches_a_fresh_start():
    """A Lees–Edwards system is periodic in strain (period L_x/L_y, thesis §3.3): after
    10⁶ strain units the box must behave as at strain 0.  The offset is kept folded
    into [−L_x/2, L_x/2), so float32 loses nothing; a box that accumulated the strain
    would have an offset of 10⁶ L_y, whose float32 spacing (0.06 L_y) exceeds the
    offset change of a step (γ̇ L_y Δt = 0.02 L_y).  Both runs must give the same
    temperature and shear stress, and the offset must advance by exactly γ̇ L_y t."""
    shear_rate, dt, steps = 0.5, 0.04, 1500
    scene = make_scene(
        precision="float32",
        particles={"density": 3.0, "count": 750},
        integrator={"dt": dt, "lambda": 0.65},
        flow={"kind": "shear", "shear_rate": shear_rate},
    )
    simulation = build(scene)
    lx, ly, _ = scene.box.lengths
    fresh = driver.run(simulation, simulation.init_fn(), 250, 250)
    folded = (MILLION_STRAIN * ly) % lx
    folded = folded - lx * math.floor(folded / lx + 0.5)
    late = fresh.set(box_state=fresh.box_state.set(offset=jnp.asarray(folded, jnp.float32)))
    results = {}
    for name, start in (("fresh", fresh), ("late", late)):
        final, series = _series(simulation, start, steps, 250)
        assert int(final.flags) == 0
        assert np.all(np.isfinite(np.asarray(final.velocities)))
        moved = float(final.box_state.offset) - float(start.box_state.offset)
        expected = shear_rate * ly * steps * dt
        wrapped = (moved - expected) - lx * round((moved - expected) / lx)
        # float32 round-off of one add per step, ≤ ½ ulp(L_x/2) each.
        assert abs(wrapped) < steps * 0.5 * np.spacing(np.float32(lx / 2))
        shear_stress = series["pressure_tensor"][:, 0, 1]
        results[name] = {
            "temperature": block_average(series["temperature"], 15),
            "shear_stress": block_average(shear_stress, 15),
        }
    for key in ("temperature", "shear_stress"):
        (mean_a, error_a), (mean_b, error_b) = results["fresh"][key], results["late"][key]
        assert abs(float(mean_a) - float(mean_b)) < 4 * math.hypot(error_a, error_b), key


def test_oscillatory_shear_keeps_its_phase_over_two_million_steps():
    """γ̇(t) = γ̇0 cos(ω t) at t = n Δt must match the exact phase after n = 2·10⁶
    steps.  The box clock is float64 kept within one period, so the phase error is
    that of summing Δt n times in float64 (≤ n ulp(2π) ≈ 2·10⁶ · 9·10⁻¹⁶)."""
    box = LeesEdwardsBox((6.0, 6.0, 6.0), shear_rate=1.0, oscillation_frequency=1.0)
    dt, n = 0.04, 2_000_000
    start = box.initial_state(jnp.float32)
    advance = jax.jit(lambda s: jax.lax.fori_loop(0, n, lambda _, s: box.advance(s, 0.0, dt), s))
    final = advance(start)
    exact_phase = math.fmod(n * dt, 2 * math.pi)
    assert abs(float(final.time) - exact_phase) < n * np.spacing(2 * math.pi)
    assert float(box.bind(final).current_shear_rate) == pytest.approx(
        math.cos(exact_phase), abs=2 * np.spacing(np.float32(1.0))
    )
    assert box.bind(final).current_shear_rate.dtype == jnp.float32


def fene_dumbbell_solution(
    dt, spring_constant, shear_rate=2.0, count=750, precision="float32", max_extension=2.0
):
    """FENE dumbbells (Q0 = 2) in a DPD solvent (20 % beads), by default under strong
    shear (γ̇ = 2 heats the peculiar temperature to ≈ 1.5: a hard case); no flow
    with shear_rate None."""
    flow = None if shear_rate is None else {"kind": "shear", "shear_rate": shear_rate}
    return make_scene(
        precision=precision,
        particles={
            "density": 3.0,
            "count": count,
            "species": [
                {"name": "solvent", "fraction": 0.8},
                {"name": "bead", "fraction": 0.2},
            ],
        },
        polymers=[
            {
                "species": "bead",
                "beads": 2,
                "bond": {
                    "law": "fene",
                    "spring_constant": spring_constant,
                    "max_extension": max_extension,
                },
            }
        ],
        integrator={"dt": dt, "lambda": 0.65},
        flow=flow,
        output={"observables": ["temperature", "pressure", "conformation"]},
    )


def test_fene_dumbbells_in_strong_shear_stay_below_q0():
    """H = 3, Q0 = 2 (b = H Q0²/k_BT = 12) at γ̇ = 2, Δt = 0.01: the springs stretch
    beyond their equilibrium size ⟨Q²⟩ = 3 b/(b+5) k_BT/H (thesis eq. 4.8; 0.84 rms)
    and stay below Q0, finite, with no error flag, over 2000 steps (the FENE force
    diverges at Q0, so an unstable integration shows as an overstretched spring)."""
    spring_constant, max_extension = 3.0, 2.0
    scene = fene_dumbbell_solution(0.01, spring_constant)
    simulation = build(scene)
    state, series = _series(simulation, simulation.init_fn(), 2000, 500)
    assert int(state.flags) == 0
    assert np.all(np.isfinite(np.asarray(state.positions)))
    b = spring_constant * max_extension**2
    equilibrium_rms = math.sqrt(3 * b / (b + 5) / spring_constant)
    q_sq = series["bead/bond_length_sq"]
    assert math.sqrt(q_sq[len(q_sq) // 2 :].mean()) > 1.1 * equilibrium_rms


def test_fene_dumbbells_with_a_time_step_too_large_stop_with_a_named_error():
    """Soft FENE springs (H = 1, Q0 = 2, b = 4: near Q0 already at rest) with Δt = 0.04
    jump past Q0 under the same shear: the run must stop with the overstretched-spring
    (or unstable-integration) message naming integrator.dt, never with NaN."""
    scene = fene_dumbbell_solution(0.04, spring_constant=1.0)
    simulation = build(scene)
    with pytest.raises(errors.SimulationError, match=r"integrator\.dt") as raised:
        driver.run(simulation, simulation.init_fn(), 2000, 100)
    named = (errors.StepError.SPRING_OVERSTRETCHED.message, errors.StepError.NON_FINITE.message)
    assert any(message in str(raised.value) for message in named)


@pytest.mark.parametrize(("flow", "deborah"), [("shear", 1000.0), ("planar_elongation", 10.0)])
def test_brownian_fene_dumbbells_at_high_deborah_number_stay_below_q0(flow, deborah):
    """Öttinger's semi-implicit scheme solves the FENE cubic for the root below Q0
    (jaxdpd.brownian.dynamics), so no step reaches Q0 however strong the flow or
    coarse the step (here De Δt = 10 in shear).  In planar elongation above the
    coil–stretch transition (De > 1/2) the dumbbells reach ≥ 95 % of Q0 = √b."""
    spring = bd.FENE(50.0)
    kappa = bd.velocity_gradient(flow, deborah)
    state = bd.equilibrium_state(jax.random.key(1), spring, 512)
    final, _ = bd.simulate(
        jax.random.key(2), state, kappa, spring, 0.01, n_samples=20, sample_every=100
    )
    length = jnp.linalg.norm(final.connector, axis=-1)
    assert bool(jnp.all(jnp.isfinite(final.connector)))
    assert float(length.max()) < math.sqrt(50.0)
    assert float(jnp.max(final.max_extension2)) < 1.0
    if flow == "planar_elongation":
        assert float(jnp.median(length)) > 0.95 * math.sqrt(50.0)


def test_mpcd_with_most_cells_empty_conserves_energy_and_momentum():
    """SRD at 0.3 particles per cell (74 % of the cells empty, Poisson) must run
    without NaN: empty and singly occupied cells have no relative velocity to rotate.
    The SRD step conserves momentum and kinetic energy exactly (Malevanets & Kapral
    1999; Mussawisade et al. 2005 §II) when no thermostat acts, so both stay at their
    initial values to float64 round-off."""
    from mpcd_scenes import pure_solvent

    from jaxdpd.scene import Scene

    scene = Scene.from_dict(pure_solvent(0.3, 130.0, 0.1, 8))
    simulation = build(scene)
    start = simulation.init_fn()
    final = driver.run(simulation, start, 400, 200)
    assert int(final.flags) == 0
    v0, v1 = np.asarray(start.velocities), np.asarray(final.velocities)
    assert np.all(np.isfinite(v1))
    np.testing.assert_allclose(v1.sum(axis=0), v0.sum(axis=0), atol=1e-10 * np.abs(v0).sum())
    assert (v1**2).sum() == pytest.approx((v0**2).sum(), rel=1e-10)


def small_dumbbell_solution():
    """300 particles at rest, float64: FENE H = 3, Q0 = 2 dumbbells."""
    return fene_dumbbell_solution(0.04, 3.0, shear_rate=None, count=300, precision="float64")


@pytest.mark.slow  # about 45 s; pathwise derivatives are also in test_brownian_fit
def test_short_pathwise_derivative_equals_central_finite_differences():
    """Over 20 steps the trajectory is a smooth function of H (same counter-based
    noise for every H), so jvp must equal the central difference
    [⟨Q²⟩(H + h) − ⟨Q²⟩(H − h)]/(2h) up to its O(h²) truncation and round-off
    (h = 1e-5 in float64: both below 1e-6 relative)."""
    simulation = build(small_dumbbell_solution())
    state = simulation.init_fn()
    parameter = {"bond": {"bead": "spring_constant"}}
    _, slope, growth = pathwise_derivative(simulation, state, 20, parameter, "bead/bond_length_sq")
    h = 1e-5
    ends = []
    for sign in (1, -1):
        shifted = with_parameters(state, {"bond": {"bead": {"spring_constant": 3.0 + sign * h}}})
        _, samples = driver._scan_chunk(simulation.step_fn, shifted, 20)
        ends.append(float(np.mean(samples["bead/bond_length_sq"])))
    assert slope == pytest.approx((ends[0] - ends[1]) / (2 * h), rel=1e-6)
    assert growth < MAX_TANGENT_GROWTH


@pytest.mark.slow
def test_pathwise_derivative_through_ten_thousand_steps_warns_with_the_estimator_to_use():
    """Through 10⁴ steps (400 time units) the tangent of a chaotic DPD fluid grows
    like exp(λ_max t) (module docstring of jaxdpd.studies.pathwise): the derivative must not
    be returned silently but with a warning naming the fluctuation estimator."""
    simulation = build(small_dumbbell_solution())
    state = driver.run(simulation, simulation.init_fn(), 100, 100)
    with pytest.warns(PathwiseDerivativeWarning, match=r"dpd_fit\.measure_sensitivity"):
        _, _, growth = pathwise_derivative(
            simulation, state, 10_000, {"bond": {"bead": "spring_constant"}}, "bead/bond_length_sq"
        )
    assert not growth <= MAX_TANGENT_GROWTH
