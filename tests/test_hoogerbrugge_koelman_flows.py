"""The Hoogerbrugge–Koelman fluid (Europhys. Lett. 19, 155 (1992)) in steady shear,
oscillatory shear and planar elongation (Lees–Edwards and Kraynik–Reinelt boxes,
peculiar velocities, SLLOD free flight: jaxdpd.solvents.hoogerbrugge_koelman).

References:
- SLLOD conserves the total peculiar momentum, d/dt Σ c = Σ F − L Σ c = 0 from zero
  (thesis eqs. 3.42–3.43), and the HK collision conserves momentum pair by pair;
- a Newtonian fluid in homogeneous shear has the laboratory profile γ̇ (y − L_y/2)
  with no kink at the moving boundary and uniform density and temperature (thesis
  §3.5.1); its stress viscosity −⟨P_yx⟩/γ̇ is the η of the fluid at rest, here from
  the decay of transverse currents (Hansen & McDonald §8.4;
  jaxdpd.observables.transverse_current), an independent measurement;
- planar elongation of a Newtonian fluid: η̄1 = 4η (docs/conventions.md), with η
  from the Lees–Edwards box;
- viscous heating: the flow puts q = P:∇u/ρ = η γ̇²/ρ (shear) or 4 η ε̇²/ρ
  (elongation) per particle and unit time into the fluid.  In mean field (the other
  particles' velocities uncorrelated, n ∫ W = 1, ⟨e e⟩ = 1/3) a collision multiplies
  a particle's peculiar velocity by 1 − ω/3 on average, its excess kinetic energy
  by (1 − ω/3)², so the steady temperature rises by (2/3) q δt / (1 − (1 − ω/3)²),
  1.45 steps' heat at ω = 4/3; this is allowed on top of the errors.

Tolerances: 4 standard errors of 20 block averages (transverse currents: the
jackknife error of 10 blocks), combined in quadrature.
"""

import numpy as np
import pytest
from test_planar_elongation import fractional_coordinates, mean_and_error
from test_shear_flow import collect_series

from jaxdpd.analysis.elongation import elongational_material_functions
from jaxdpd.engine.build import build
from jaxdpd.observables.profiles import slab_centres
from jaxdpd.observables.transverse_current import kinematic_viscosity
from jaxdpd.run import driver, ensemble
from jaxdpd.scene import Scene

DENSITY = 3.0
FLOWS = {
    "shear": ("lees_edwards", {"kind": "shear", "shear_rate": 0.01}),
    "oscillatory_shear": (
        "lees_edwards",
        {"kind": "shear", "shear_rate": 0.01, "oscillation_frequency": 0.05},
    ),
    "planar_elongation": (
        "kraynik_reinelt",
        {"kind": "planar_elongation", "elongation_rate": 0.05},
    ),
}


def hk_fluid(lengths, flow=None, precision="float64", seed=3, observables=None, **output):
    """A Hoogerbrugge–Koelman fluid (default Π0, ω, Δ, δt = 1) at ρ = 3 as a scene dict."""
    data = {
        "seed": seed,
        "precision": precision,
        "box": {"lengths": list(lengths)},
        "particles": {"density": DENSITY},
        "solvent": {"method": "hoogerbrugge_koelman"},
        "output": {"observables": observables or ["temperature", "pressure"], **output},
    }
    if flow is not None:
        data["flow"] = flow
    return data


def viscous_heating(viscosity, shear_rate, omega=4 / 3):
    """Steady temperature rise (2/3) q δt / (1 − (1 − ω/3)²), q = η γ̇²/ρ, δt = 1
    (module docstring)."""
    return (2 / 3) * viscosity * shear_rate**2 / DENSITY / (1 - (1 - omega / 3) ** 2)


def toml_text(data):
    """The scene dict `hk_fluid` writes, as a scene file."""
    flow = ", ".join(
        f"{key} = {value!r}" if isinstance(value, str) else f"{key} = {value}"
        for key, value in data["flow"].items()
    ).replace("'", '"')
    return f"""
seed = {data["seed"]}
precision = "{data["precision"]}"
[box]
lengths = {data["box"]["lengths"]}
[particles]
density = {DENSITY}
[solvent]
method = "hoogerbrugge_koelman"
[flow]
{flow.replace(", ", chr(10))}
[output]
observables = ["temperature", "pressure"]
"""


def scene_file(name, tmp_path):
    """The scene of FLOWS[name] (4 × 3 × 4, seed 5) read from a scene file, and its dict."""
    data = hk_fluid([4.0, 3.0, 4.0], FLOWS[name][1], seed=5)
    path = tmp_path / "scene.toml"
    path.write_text(toml_text(data))
    return Scene.from_toml(path), data


@pytest.mark.parametrize("name", FLOWS)
def test_a_scene_file_and_a_dict_give_one_scene_in_the_flows_box(name, tmp_path):
    scene, data = scene_file(name, tmp_path)
    assert scene == Scene.from_dict(data)
    assert scene.box.kind == FLOWS[name][0]
    assert Scene.from_dict(scene.to_dict()) == scene


@pytest.mark.parametrize(
    ("change", "message"),
    [
        ({"neighbors": {"method": "all_pairs"}}, "neighbors.method = 'all_pairs'"),
        ({"body_force": {"kind": "cosine", "amplitude": 0.01}}, "body_force: solvent.method"),
        (
            {"particles": {"density": 3.0, "species": [{"name": "a", "mass": 2.0}]}},
            r"species\[\]\.mass",
        ),
    ],
)
@pytest.mark.parametrize("name", FLOWS)
def test_what_hk_lacks_in_a_flow_is_refused_naming_the_field(name, change, message):
    """The flows come without the neighbour backends that do not know the moving
    boundaries, and without the body forces and masses HK refuses at rest."""
    data = {**hk_fluid([4.0, 3.0, 4.0], FLOWS[name][1]), **change}
    with pytest.raises(ValueError, match=message):
        Scene.from_dict(data)


@pytest.mark.parametrize("name", ["shear", "planar_elongation"])
def test_steady_flows_run_from_a_scene_file(name, tmp_path):
    """20 steps with no flag; the box strains at the set rate (Lees–Edwards offset
    γ̇ L_y t, Kraynik–Reinelt Hencky strain ε̇ t modulo the period); Σ c stays 0."""
    scene, data = scene_file(name, tmp_path)
    simulation = build(scene)
    state = driver.run(simulation, simulation.init_fn(), 20, 20)
    assert int(state.flags) == 0
    if name == "shear":
        assert float(state.box_state.offset) == pytest.approx(0.01 * 20 * 3.0, rel=1e-9)
    else:
        period = simulation.box.period
        strain = (0.05 * 20 + period / 2) % period - period / 2
        assert float(state.box_state.strain) == pytest.approx(strain, rel=1e-9)
    velocities = np.asarray(state.velocities)
    assert np.abs(velocities.sum(axis=0)).max() < 1e-12 * np.abs(velocities).sum()


def test_oscillatory_shear_conserves_momentum_and_holds_the_temperature(tmp_path):
    """From a scene file, two replicas (float64), at rest and in oscillatory shear
    γ̇(t) = 0.01 cos(0.05 t), 500 steps after 100 of equilibration: the offset is
    the box's midpoint sum Σ γ̇(t_n + δt/2) L_y δt, Σ c = 0 to round-off and the
    peculiar temperature equals that at rest within the errors plus the viscous
    heating (module docstring; ≤ 7e-6 at η < 0.2)."""
    scene, _ = scene_file("oscillatory_shear", tmp_path)
    simulation = build(scene)
    batch = ensemble.replicate(simulation, simulation.init_fn(), flow_rates=[0.0, 0.01])
    batch = driver.run(simulation, batch, 100, 100)
    final, series = collect_series(simulation, batch, 500, 100)
    midpoints = np.arange(600) + 0.5
    offset = np.sum(0.01 * np.cos(0.05 * midpoints)) * 3.0
    assert float(final.box_state.offset[1]) == pytest.approx(offset, rel=1e-9)
    velocities = np.asarray(final.velocities)
    assert np.abs(velocities.sum(axis=1)).max() < 1e-12 * np.abs(velocities).sum()
    temperature, error = mean_and_error(series["temperature"], axis=1)
    heating = viscous_heating(0.2, 0.01)  # η ≈ 0.11 (the slow tests below)
    assert abs(temperature[1] - temperature[0]) < 4 * np.hypot(*error) + heating, (
        temperature,
        error,
    )
    assert int(final.flags.max()) == 0


SHEAR_RATE = 0.01
ELONGATION_RATE = 0.005  # strains at the rate of a shear of 2ε̇ = γ̇
CUBE = [6.0, 6.0, 6.0]  # N = 648


def production(data, steps, equilibration=500, chunk=500):
    """The series of `steps` steps after `equilibration` (the fluid's own temperature
    builds up from the random start within ~50 steps)."""
    simulation = build(Scene.from_dict(data))
    state = driver.run(simulation, simulation.init_fn(), equilibration, equilibration)
    return simulation, *collect_series(simulation, state, steps, chunk)


@pytest.fixture(scope="module")
def sheared():
    """The fluid in a 6³ Lees–Edwards box at γ̇ = 0.01, 4000 steps (float64)."""
    flow = {"kind": "shear", "shear_rate": SHEAR_RATE}
    observables = ["temperature", "pressure", "profile"]
    _, _, series = production(hk_fluid(CUBE, flow, observables=observables, profile_bins=6), 4000)
    return series


@pytest.fixture(scope="module")
def at_rest():
    """The same fluid at rest (6³, seed 4, float32), 10 000 steps: kinematic viscosity
    from transverse currents at n = 1, 2 extrapolated to k → 0 (10 jackknife
    blocks of 1000 steps, ≫ the decay time 1/(ν k²) ≈ 25 steps) and temperature."""
    data = hk_fluid(
        CUBE,
        precision="float32",
        seed=4,
        observables=["temperature", "transverse_current"],
        current_modes=2,
    )
    simulation = build(Scene.from_dict(data))
    state = driver.run(simulation, simulation.init_fn(), 500, 500)
    currents, temperatures = [], []
    for _ in range(10):
        state, samples, _ = driver.run_chunk(simulation, state, 1000)
        currents.append(np.asarray(samples["transverse_current"]))
        kinetic = np.trace(np.asarray(samples["kinetic"], np.float64), axis1=1, axis2=2)
        temperatures.append(kinetic / (3 * (simulation.scene.n_particles - 1)))
    viscosity = kinematic_viscosity(np.concatenate(currents), 1.0, CUBE[0], n_blocks=10)
    return viscosity, mean_and_error(np.concatenate(temperatures))


def shear_viscosity(series):
    """η = −⟨P_yx⟩/γ̇ and its block error."""
    return mean_and_error(-series["pressure_tensor"][:, 1, 0] / SHEAR_RATE)


@pytest.mark.slow
def test_sheared_fluid_is_linear_without_a_kink_uniform_and_holds_its_temperature(sheared, at_rest):
    """Six slabs along y: v_x = γ̇ (y − L_y/2) in each, the two next to the moving
    boundary included; density ρ and slab temperature uniform; the temperature is
    that at rest within the errors plus the viscous heating."""
    centres = np.asarray(slab_centres(CUBE[1], 6))
    velocity, velocity_error = mean_and_error(sheared["profile/velocity_x"])
    expected = SHEAR_RATE * (centres - CUBE[1] / 2)
    assert np.all(np.abs(velocity - expected) < 4 * velocity_error), (velocity, expected)
    density, density_error = mean_and_error(sheared["profile/density"])
    assert np.all(np.abs(density - DENSITY) < 4 * density_error), density
    slabs, slab_error = mean_and_error(sheared["profile/temperature"])
    overall, overall_error = mean_and_error(sheared["temperature"])
    assert np.all(np.abs(slabs - np.mean(slabs)) < 4 * slab_error), slabs
    _, (rest, rest_error) = at_rest
    eta, _ = shear_viscosity(sheared)
    print(
        f"HK shear: v_x {np.round(velocity, 5)} ± {np.round(velocity_error, 5)} "
        f"(expected {np.round(expected, 5)}); k_BT {overall:.6f} ± {overall_error:.6f}, "
        f"at rest {rest:.6f} ± {rest_error:.6f}"
    )
    allowed = 4 * np.hypot(overall_error, rest_error) + viscous_heating(eta, SHEAR_RATE)
    assert abs(overall - rest) < allowed, (overall, overall_error, rest, rest_error)


@pytest.mark.slow
def test_stress_viscosity_equals_the_transverse_current_viscosity_at_rest(sheared, at_rest):
    """−⟨P_yx⟩/γ̇ in the Lees–Edwards box = ρ ν from the transverse-current decay of the
    fluid at rest, within 4 combined standard errors; the stress is symmetric
    (central collisions): P_xy = P_yx within errors."""
    eta, error = shear_viscosity(sheared)
    viscosity, _ = at_rest
    nu, nu_error = viscosity["extrapolated"], viscosity["extrapolated_error"]
    print(
        f"HK η: stress {eta:.4f} ± {error:.4f}, transverse currents ρν = "
        f"{DENSITY * nu:.4f} ± {DENSITY * nu_error:.4f}"
    )
    parts = {
        name.rsplit("/", 1)[1]: round(float(np.mean(-values[:, 1, 0])) / SHEAR_RATE, 4)
        for name, values in sheared.items()
        if name.startswith("pressure_tensor_part/")
    }
    print(f"HK η by part: {parts}")
    assert abs(eta - DENSITY * nu) < 4 * np.hypot(error, DENSITY * nu_error)
    assert error < 0.05 * eta and nu_error < 0.1 * nu  # a comparison with teeth
    asymmetry, asymmetry_error = mean_and_error(
        sheared["pressure_tensor"][:, 0, 1] - sheared["pressure_tensor"][:, 1, 0]
    )
    assert abs(asymmetry) < 4 * asymmetry_error + 1e-12


@pytest.mark.slow
def test_planar_elongation_has_the_trouton_ratio_and_holds_temperature(sheared, at_rest):
    """6³ Kraynik–Reinelt box at ε̇ = 0.005 (float64, 4000 steps, 21 periods):
    η̄1 = 4η with η the Lees–Edwards viscosity at γ̇ = 2ε̇; Σ c = 0 to round-off; the
    temperature is that at rest within the errors plus the viscous heating
    (q = 4ηε̇²/ρ = ηγ̇²/ρ)."""
    flow = {"kind": "planar_elongation", "elongation_rate": ELONGATION_RATE}
    simulation, state, series = production(hk_fluid(CUBE, flow), 4000)
    functions = elongational_material_functions(series, ELONGATION_RATE)
    eta1, eta1_error = functions["eta1"]
    eta, eta_error = shear_viscosity(sheared)
    print(f"HK η̄1/4 = {eta1 / 4:.4f} ± {eta1_error / 4:.4f}, η = {eta:.4f} ± {eta_error:.4f}")
    assert abs(eta1 - 4 * eta) < 4 * np.hypot(eta1_error, 4 * eta_error)
    assert eta1_error < 0.1 * eta1
    velocities = np.asarray(state.velocities)
    assert np.abs(velocities.sum(axis=0)).max() < 1e-12 * np.abs(velocities).sum()
    temperature, error = mean_and_error(series["temperature"])
    _, (rest, rest_error) = at_rest
    print(f"HK elongation: k_BT {temperature:.6f} ± {error:.6f}, at rest {rest:.6f}")
    allowed = 4 * np.hypot(error, rest_error) + viscous_heating(eta, 2 * ELONGATION_RATE)
    assert abs(temperature - rest) < allowed, (temperature, error, rest, rest_error)
    assert int(state.flags) == 0


@pytest.mark.slow
def test_nothing_drifts_over_200_kraynik_reinelt_periods_in_float32():
    """4 × 3 × 4 box (N = 144) at ε̇ = 0.05, float32, 200 periods (3850 steps): at
    every chunk end all particles are in the primary cell and distinct, Σ c = 0 to
    float32 round-off (1e-5 of Σ|c|), no flag; the strain is ε̇ t modulo the period;
    the temperature (raised by viscous heating to a steady value) and η̄1 of the
    first and second halves agree within 4 combined errors, and density is uniform
    over 3 × 3 bins of the cell's fractional coordinates."""
    flow = {"kind": "planar_elongation", "elongation_rate": 0.05}
    simulation = build(Scene.from_dict(hk_fluid([4.0, 3.0, 4.0], flow, precision="float32")))
    box = simulation.box
    chunk = 175
    steps = int(np.ceil(200 * box.period / 0.05 / chunk)) * chunk
    state = driver.run(simulation, simulation.init_fn(), chunk, chunk)
    parts, counts = {}, []

    def keep(result):
        state = result.state
        for name, values in result.series.items():
            parts.setdefault(name, []).append(np.asarray(values, np.float64))
        fractions = fractional_coordinates(box, state.box_state, state.positions)
        assert np.all(np.abs(fractions) <= 0.5 + 1e-5)
        assert len(np.unique(np.asarray(state.positions), axis=0)) == len(fractions)
        velocities = np.asarray(state.velocities, np.float64)
        assert np.abs(velocities.sum(axis=0)).max() < 1e-5 * np.abs(velocities).sum()
        cells = np.floor((np.clip(fractions[:, [0, 2]], -0.5, 0.5 - 1e-7) + 0.5) * 3)
        counts.append(np.bincount((cells[:, 0] * 3 + cells[:, 1]).astype(int), minlength=9))

    final = driver.run(simulation, state, steps, chunk, on_chunk=keep)
    assert int(final.flags) == 0
    period = box.period
    strain = (0.05 * (steps + chunk) + period / 2) % period - period / 2
    assert abs(float(final.box_state.strain) - strain) < 1e-3
    series = {name: np.concatenate(values) for name, values in parts.items()}
    half = len(series["temperature"]) // 2
    halves = [
        {name: values[k * half : (k + 1) * half] for name, values in series.items()}
        for k in range(2)
    ]
    first, second = (mean_and_error(h["temperature"]) for h in halves)
    print(f"HK 200 periods: k_BT halves {first}, {second}")
    assert abs(first[0] - second[0]) < 4 * np.hypot(first[1], second[1]), (first, second)
    (eta_a, error_a), (eta_b, error_b) = (
        elongational_material_functions(h, 0.05)["eta1"] for h in halves
    )
    print(f"HK 200 periods: η̄1 halves {eta_a:.4f} ± {error_a:.4f}, {eta_b:.4f} ± {error_b:.4f}")
    assert abs(eta_a - eta_b) < 4 * np.hypot(error_a, error_b), (eta_a, eta_b)
    density, density_error = mean_and_error(counts)
    assert np.all(np.abs(density - 144 / 9) < 4 * density_error), (density, density_error)
