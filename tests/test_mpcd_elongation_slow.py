"""MPCD (SRD) in planar elongation against the same fluid in Lees–Edwards shear
(statistical; docs/solvent_flows/mpcd.md derives the references).

The SRD collisional stress is not symmetric (Ihle, Tüzel & Kroll, Phys. Rev. E 72,
046707 (2005)): in mean field a collision changes v_i by −γ_α L (r_i − r̄_c), which
gives the collisional pressure tensor P_coll = −η_coll (12/a²) Q Lᵀ with Q the
second moment of a point in the cell (a²/12 · 1 for a cube) and η_coll of
Mussawisade et al. (J. Chem. Phys. 123, 144905 (2005), eq. 6).  Hence
- shear (L_xy = γ̇): −P_yx/γ̇ = η_kin + η_coll (the viscosity of tests/test_mpcd_shear),
  −P_xy/γ̇ = η_kin: the kinetic stress is symmetric, the collisional one is all in P_yx;
- planar elongation (L = diag(−ε̇, 0, ε̇)): the kinetic part gives η̄1 = 4 η_kin (an
  isotropic symmetric stress, Trouton), the collisional part 2κ η_coll with
  κ = (|e_0|² + |e_2|²)/(2a²) averaged over the period, e_0, e_2 the in-plane cell
  edges (1 for a square cell; the lattice cells of the Gauss-reduced Kraynik–Reinelt
  box give κ = 1.039 for case 1).  So η̄1 = 4η_s + 2(κ − 1)η_coll with η_s = η_kin +
  η_coll/2 the viscosity of the symmetric stress, not 4(η_kin + η_coll).
Both fluids are thermostatted (cell-level Maxwell–Boltzmann scaling), float32, ρ = 10,
α = 130°, h = 0.1 (collision-dominated: η_coll ≈ 8.2, η_kin ≈ 0.5), rates 0.2.

Tolerances: 4 standard errors of 20 block averages, combined in quadrature.
"""

import numpy as np
import pytest
from mpcd_scenes import pure_solvent
from test_planar_elongation import assert_homogeneous, bin_counts_and_temperatures, mean_and_error

from jaxdpd.engine.build import build
from jaxdpd.geometry.boxes.kraynik_reinelt_lattice import kraynik_reinelt_case
from jaxdpd.run import driver
from jaxdpd.scene import Scene

RATE = 0.2
PERIODS = 200
CHUNK = 500


def cell_shape_factor(case: int, samples: int = 20000) -> float:
    """κ: (|e_0|² + |e_2|²)/(2 · area) of the reduced primary cell, averaged over a
    period of uniformly advancing strain (the cells are the cell scaled by 1/n)."""
    geometry = kraynik_reinelt_case(case)
    strains = np.linspace(-geometry.period / 2, geometry.period / 2, samples + 1)[:-1]
    ratios = []
    for strain in strains:
        cell = geometry.primary_cell(strain)
        ratios.append(np.sum(cell**2) / (2 * abs(np.linalg.det(cell))))
    return float(np.mean(ratios))


def flowing_fluid(flow, lengths):
    return Scene.from_dict(
        pure_solvent(
            10.0,
            130.0,
            0.1,
            6,
            seed=3,
            precision="float32",
            box={"lengths": lengths},
            solvent={"thermostat": "maxwell_boltzmann_scaling"},
            output={"observables": ["temperature", "pressure"]},
            flow=flow,
        )
    )


def run(scene, steps):
    """Time series after 500 equilibrating collisions, and the chunk-end states."""
    simulation = build(scene)
    state = driver.run(simulation, simulation.init_fn(), CHUNK, CHUNK)
    parts, states = {}, []

    def keep(result):
        states.append(result.state)
        for name, values in result.series.items():
            parts.setdefault(name, []).append(np.asarray(values, np.float64))

    driver.run(simulation, state, steps, CHUNK, on_chunk=keep)
    return simulation, {name: np.concatenate(v) for name, v in parts.items()}, states


def viscosity_parts(series):
    """(kinetic incl. free flight, collisional) pressure tensor series."""
    kinetic = series["pressure_tensor_part/kinetic"] + series["pressure_tensor_part/streaming"]
    return kinetic, series["pressure_tensor_part/collision"]


@pytest.fixture(scope="module")
def runs():
    shear = flowing_fluid({"kind": "shear", "shear_rate": RATE}, [6.0] * 3)
    elongation = flowing_fluid(
        {"kind": "planar_elongation", "elongation_rate": RATE}, [6.0, 4.0, 6.0]
    )
    period = kraynik_reinelt_case(1).period
    steps = int(np.ceil(PERIODS * period / (RATE * 0.1) / CHUNK)) * CHUNK
    return run(shear, steps), run(elongation, steps), steps


@pytest.mark.slow
def test_trouton_ratio_against_the_lees_edwards_viscosity(runs):
    """η̄1 = −⟨P_zz − P_xx⟩/ε̇ equals 4η_kin + 2κη_coll from the Lees–Edwards run, part
    by part and in total (module docstring); the Kikuchi viscosity −P_yx/γ̇ times 4
    would be 80 % too high."""
    (_, shear, _), (_, elongation, _), _ = runs
    kappa = cell_shape_factor(1)
    kinetic, collision = viscosity_parts(shear)
    eta_kin = -(kinetic[:, 0, 1] + kinetic[:, 1, 0]) / (2 * RATE)
    eta_coll = -collision[:, 1, 0] / RATE
    kinetic, collision = viscosity_parts(elongation)
    measured = {
        "kinetic": mean_and_error(-(kinetic[:, 2, 2] - kinetic[:, 0, 0]) / RATE),
        "collision": mean_and_error(-(collision[:, 2, 2] - collision[:, 0, 0]) / RATE),
    }
    pressure = elongation["pressure_tensor"]
    measured["total"] = mean_and_error(-(pressure[:, 2, 2] - pressure[:, 0, 0]) / RATE)
    expected = {
        "kinetic": mean_and_error(4 * eta_kin),
        "collision": mean_and_error(2 * kappa * eta_coll),
        "total": mean_and_error(4 * eta_kin + 2 * kappa * eta_coll),
    }
    kikuchi = mean_and_error(eta_kin + eta_coll)[0]
    print(f"κ = {kappa:.4f}; 4 η(−P_yx) = {4 * kikuchi:.3f}")
    for name, (value, error) in measured.items():
        reference, reference_error = expected[name]
        print(
            f"η̄1 {name}: {value:.4f} ± {error:.4f}, shear {reference:.4f} ± {reference_error:.4f}"
        )
        assert abs(value - reference) < 4 * np.hypot(error, reference_error), name
    assert measured["total"][1] < 0.01 * measured["total"][0]


@pytest.mark.slow
def test_two_hundred_periods_keep_temperature_density_and_momentum(runs):
    """Over 200 Kraynik–Reinelt periods (float32): the strain is ε̇t modulo the
    period; no flag; the total peculiar momentum is 0 at every chunk end (1e-5 of
    Σ|c|); density and temperature are uniform over 3 × 3 bins of the fractional
    coordinates (chunk-end samples); the temperature of the first and last quarters
    agree (nothing drifts) and stays within 1 % of k_BT.  The MBS thermostat holds
    the relative velocities in each cell at k_BT; after the collision the peculiar
    velocities also hold the flow across the cell, ΔT = ε̇² κ a² (ρ − 1 + e^−ρ)/(18ρ)
    = 0.002 here (docs/solvent_flows/mpcd.md), printed with the measured excess."""
    _, (simulation, series, states), steps = runs
    box = simulation.box
    n = simulation.scene.n_particles
    assert RATE * 0.1 * steps / box.period >= PERIODS
    elapsed = RATE * 0.1 * (steps + CHUNK)
    strain = (elapsed + box.period / 2) % box.period - box.period / 2
    assert abs(float(states[-1].box_state.strain) - strain) < 2e-3
    counts, temperatures = [], []
    for state in states:
        assert int(state.flags) == 0
        velocities = np.asarray(state.velocities, np.float64)
        assert np.abs(velocities.sum(axis=0)).max() < 1e-5 * np.abs(velocities).sum()
        count, temperature = bin_counts_and_temperatures(box, state)
        counts.append(count)
        temperatures.append(temperature)
    assert_homogeneous(counts, temperatures, n)
    quarter = len(series["temperature"]) // 4
    first = mean_and_error(series["temperature"][:quarter])
    last = mean_and_error(series["temperature"][-quarter:])
    assert abs(first[0] - last[0]) < 4 * np.hypot(first[1], last[1]), (first, last)
    mean_temperature = float(np.mean(series["temperature"]))
    rho, kappa = 10.0, cell_shape_factor(1)
    in_cell = RATE**2 * kappa * (rho - 1 + np.exp(-rho)) / (18 * rho)
    print(f"k_BT = {mean_temperature:.5f}; in-cell flow term {in_cell:.5f}")
    assert abs(mean_temperature - 1) < 0.01
