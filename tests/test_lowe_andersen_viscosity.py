"""Viscosity of a Lowe–Andersen fluid: Green–Kubo at rest against shear flow.

References: Green–Kubo relation (Allen & Tildesley, Computer Simulation of Liquids,
2nd ed. (2017), §2.7); Lees–Edwards shear with SLLOD and laboratory relative
velocities for the thermostat (thesis §3.3–3.4, eq. 3.18); the stress with the
thermostat's impulse part (thesis eq. 3.47).  In the linear regime the viscosity
measured from the mean shear stress equals the one from equilibrium fluctuations.
"""

import numpy as np
import pytest
from conftest import scene_dict
from scipy import signal

from jaxdpd.analysis.green_kubo import running_integral, shear_viscosity
from jaxdpd.analysis.statistics import block_average
from jaxdpd.engine.build import build
from jaxdpd.run import driver
from jaxdpd.scene import Scene


def autoregressive_stress(length: int, phi: float, rng):
    """(T, 3, 3) tensors whose three off-diagonal parts are AR(1) series of unit
    variance, C(k) = φ^k (independent, symmetric tensor)."""
    noise = rng.normal(size=(length, 3)) * np.sqrt(1 - phi**2)
    noise[0] = rng.normal(size=3)  # stationary start
    series = signal.lfilter([1.0], [1.0, -phi], noise, axis=0)
    tensors = np.zeros((length, 3, 3))
    for k, (a, b) in enumerate(((0, 1), (0, 2), (1, 2))):
        tensors[:, a, b] = tensors[:, b, a] = series[:, k]
    return tensors


def test_green_kubo_integral_of_a_known_correlation():
    """AR(1) with C(k) = φ^k, V = k_BT = Δt = 1: the trapezoidal integral to lag K is
    Σ_{k<K} φ^k − ½ − ½ φ^(K−1) → 1/(1 − φ) − ½ = 4.5 for φ = 0.8 (K = 60, φ^59 ≈
    2e-6).  Within four block standard errors, which must be below 3 %."""
    rng = np.random.default_rng(0)
    tensors = autoregressive_stress(400_000, 0.8, rng)
    eta, error = shear_viscosity(tensors, 1.0, 1.0, 1.0, 60, n_blocks=20)
    expected = 1 / (1 - 0.8) - 0.5
    assert error < 0.03 * expected
    assert abs(eta - expected) < 4 * error, (eta, error)
    running = running_integral(tensors, 1.0, 1.0, 1.0, 3)
    assert running[0] == 0.0  # the integral to lag 0 vanishes


def lowe_andersen_fluid(flow=None) -> Scene:
    """ρ = 3, a = 25, Γ = 25 (ΓΔt = 0.25), Δt = 0.01, 1000 particles."""
    data = scene_dict(seed=21, particles={"count": 1000}, integrator={"dt": 0.01}, flow=flow)
    data["integrator"].pop("lambda")
    data["solvent"] = {"method": "lowe_andersen", "kT": 1.0, "collision_frequency": 25.0}
    return Scene.from_dict(data)


def pressure_series(scene, equilibration: int, steps: int):
    simulation = build(scene)
    state = driver.run(simulation, simulation.init_fn(), equilibration, 500)
    parts = {}

    def keep(result):
        for name in ("pressure_tensor", "pressure_tensor_part/impulse", "temperature"):
            parts.setdefault(name, []).append(np.asarray(result.series[name], np.float64))

    driver.run(simulation, state, steps, 500, on_chunk=keep)
    return {name: np.concatenate(values) for name, values in parts.items()}


@pytest.mark.slow
def test_shear_flow_viscosity_equals_green_kubo():
    """η = −⟨P_xy⟩/γ̇ under Lees–Edwards shear at γ̇ = 0.2 (linear regime, thesis
    fig. 4-5) equals the Green–Kubo η at rest within four combined standard errors
    (≈ 0.8 for η ≈ 9).  The thermostat's impulse part carries most of it, which it
    can only do through laboratory relative velocities (thesis §3.4); its viscosity
    −⟨P^impulse_xy⟩/γ̇ must be positive by many standard errors."""
    at_rest = pressure_series(lowe_andersen_fluid(), 500, 20_000)
    volume = 1000 / 3.0
    eta_rest, error_rest = shear_viscosity(at_rest["pressure_tensor"], volume, 1.0, 0.01, 50)
    shear_rate = 0.2
    sheared = pressure_series(
        lowe_andersen_fluid({"kind": "shear", "shear_rate": shear_rate}), 1000, 5_000
    )
    mean, error = block_average(-sheared["pressure_tensor"][:, 0, 1] / shear_rate, 20)
    combined = float(np.hypot(error, error_rest))
    assert abs(float(mean) - eta_rest) < 4 * combined, (float(mean), eta_rest, combined)
    impulse, impulse_error = block_average(
        -sheared["pressure_tensor_part/impulse"][:, 0, 1] / shear_rate, 20
    )
    assert float(impulse) > 10 * float(impulse_error), (float(impulse), float(impulse_error))
    temperature, temperature_error = block_average(sheared["temperature"], 20)
    assert abs(float(temperature) - 1.0) < 5e-3, (float(temperature), float(temperature_error))
