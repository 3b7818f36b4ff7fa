"""Sheared DPD fluid: Lees–Edwards boundaries with SLLOD (thesis §3.3, §3.5).

References:
- homogeneous simple shear: laboratory velocity u_x = γ̇ (y − L_y/2) with no kink at
  the moving boundary, uniform density and (peculiar) temperature across y (thesis
  §3.5.1);
- SLLOD conserves the total peculiar momentum exactly when it starts at zero:
  d/dt Σ c = Σ F − L Σ c with Σ F = 0 (thesis eqs. 3.42–3.43);
- Newtonian viscosity two ways in one run: η = −⟨P_xy⟩/γ̇ from the Irving–Kirkwood
  stress (thesis eq. 3.46) and η = ρ F/(k² A) from the amplitude A of the flow
  driven by a cosine body force F cos(k y) (periodic Poiseuille; Backer et al.,
  J. Chem. Phys. 122, 154503 (2005)).  For a Newtonian fluid the two responses
  superpose: the mean stress of the cosine flow and the cosine projection of the
  linear profile both vanish.  The DPD fluid stays Newtonian below γ̇ ≈ 0.3 (thesis
  fig. 4-5).

Tolerances: 4 standard errors of 20 block averages (time series), combined in
quadrature for differences.
"""

import numpy as np
import pytest
from conftest import make_scene

from jaxdpd.analysis.statistics import block_average, inverse_variance_mean
from jaxdpd.engine.build import build
from jaxdpd.forces.body_forces import cosine_profile_amplitude, cosine_wavenumber
from jaxdpd.observables.profiles import slab_centres
from jaxdpd.run import driver, ensemble

DENSITY = 3.0


def sheared_scene(shear_rate, count, precision="float64", body_force=None, bins=6, seed=7):
    return make_scene(
        seed=seed,
        precision=precision,
        particles={"density": DENSITY, "count": count},
        integrator={"dt": 0.04, "lambda": 0.65},
        flow={"kind": "shear", "shear_rate": shear_rate},
        body_force=body_force,
        output={"observables": ["temperature", "pressure", "profile"], "profile_bins": bins},
    )


def collect_series(simulation, state, steps, chunk):
    parts = {}

    def keep(result):
        for name, values in result.series.items():
            parts.setdefault(name, []).append(np.asarray(values, np.float64))

    state = driver.run(simulation, state, steps, chunk, on_chunk=keep)
    axis = 1 if ensemble.is_batch(state) else 0
    return state, {name: np.concatenate(v, axis=axis) for name, v in parts.items()}


def mean_and_error(values):
    mean, error = block_average(values, n_blocks=20)
    return np.asarray(mean), np.asarray(error)


def test_sheared_fluid_is_homogeneous_and_conserves_peculiar_momentum():
    shear_rate = 0.5
    scene = sheared_scene(shear_rate, count=1000)
    simulation = build(scene)
    state = simulation.init_fn()
    initial_momentum = np.asarray(state.velocities).sum(axis=0)
    state = driver.run(simulation, state, 250, 250)
    state, series = collect_series(simulation, state, 2000, 250)

    momenta = np.asarray(state.velocities)
    drift = np.abs(momenta.sum(axis=0) - initial_momentum).max()
    assert drift < 1e-10 * np.abs(momenta).sum()
    assert abs(float(state.box_state.offset)) <= scene.box.lengths[0] / 2

    length_y = scene.box.lengths[1]
    centres = np.asarray(slab_centres(length_y, 6))
    velocity, velocity_error = mean_and_error(series["profile/velocity_x"])
    expected = shear_rate * (centres - length_y / 2)
    # The slabs next to the moving boundary (first and last) must sit on the line too.
    assert np.all(np.abs(velocity - expected) < 4 * velocity_error), (velocity, expected)
    density, density_error = mean_and_error(series["profile/density"])
    assert np.all(np.abs(density - DENSITY) < 4 * density_error), density
    temperature, temperature_error = mean_and_error(series["profile/temperature"])
    overall, overall_error = mean_and_error(series["temperature"])
    spread = 4 * np.hypot(temperature_error, overall_error)
    assert np.all(np.abs(temperature - overall) < spread), (temperature, overall)


def viscosities(series, scene, shear_rates, force_amplitude, waves=1):
    """(η from the stress, its error, η from the cosine flow, its error) per replica."""
    length_y = scene.box.lengths[1]
    bins = scene.output.profile_bins
    stress, stress_error = mean_and_error(-series["pressure_tensor"][..., 0, 1].T)
    amplitude_series = cosine_profile_amplitude(
        slab_centres(length_y, bins), series["profile/velocity_x"], length_y, waves
    )
    amplitude, amplitude_error = mean_and_error(np.asarray(amplitude_series).T)
    k = cosine_wavenumber(length_y, waves)
    rates = np.asarray(shear_rates)
    eta_stress = stress / rates
    eta_flow = DENSITY * force_amplitude / (k * k * amplitude)
    return (
        eta_stress,
        stress_error / np.abs(rates),
        eta_flow,
        eta_flow * amplitude_error / amplitude,
    )


# Long statistical validation (3250 steps of 1500 particles): -m slow.  The default run
# keeps the sheared fluid's homogeneity and momentum (test above), the stress estimator
# (test_rheology.py) and the cosine body force's scene rules (test_drag.py).
@pytest.mark.slow
def test_viscosity_from_stress_equals_viscosity_from_cosine_flow():
    """One run at γ̇ = 0.2 with a cosine force of peak local rate ≈ 0.2 (both within
    the Newtonian range): the stress and the flow amplitude give one η."""
    shear_rate, force = 0.2, 0.035
    body_force = {"kind": "cosine", "amplitude": force}
    scene = sheared_scene(shear_rate, 1500, "float32", body_force, bins=8)
    simulation = build(scene)
    state = driver.run(simulation, simulation.init_fn(), 250, 250)
    _, series = collect_series(simulation, state, 3000, 500)
    eta_stress, stress_error, eta_flow, flow_error = viscosities(series, scene, shear_rate, force)
    assert abs(eta_stress - eta_flow) < 4 * np.hypot(stress_error, flow_error), (
        eta_stress,
        stress_error,
        eta_flow,
        flow_error,
    )
    # And it is the DPD fluid's viscosity: between the dissipative-only kinetic
    # theory estimate and a few times it (Groot & Warren 1997 measured ≈ 0.9 here).
    assert 0.5 < eta_stress < 1.5


@pytest.mark.slow
def test_solvent_viscosity_is_independent_of_shear_rate_up_to_0_1():
    """A vmapped sweep over γ̇ ∈ {0.025, 0.05, 0.1} (each replica with its own
    Lees–Edwards offset and seed) plus the cosine force: the stress viscosity is the
    same at every rate, and equals the cosine-flow viscosity, within errors."""
    rates, force = [0.025, 0.05, 0.1], 0.02
    body_force = {"kind": "cosine", "amplitude": force}
    scene = sheared_scene(0.0, 3000, "float32", body_force, bins=10)
    simulation = build(scene)
    state = driver.run(simulation, simulation.init_fn(), 500, 250)
    batch = ensemble.replicate(simulation, state, seeds=[11, 12, 13], shear_rates=rates)
    batch = driver.run(simulation, batch, 500, 250)
    _, series = collect_series(simulation, batch, 40000, 1000)
    eta_stress, stress_error, eta_flow, flow_error = viscosities(series, scene, rates, force)
    print("η(stress)", eta_stress, "±", stress_error, "η(flow)", eta_flow, "±", flow_error)
    plateau, plateau_error = inverse_variance_mean(eta_stress, stress_error)
    assert np.all(np.abs(eta_stress - plateau) < 4 * stress_error)
    flow_mean, flow_mean_error = inverse_variance_mean(eta_flow, flow_error)
    assert abs(plateau - flow_mean) < 4 * np.hypot(plateau_error, flow_mean_error)
