"""Kinetic temperature and the virial pressure tensor.

    k_BT = Σ_i m_i v_i² / (3 (N − 1))          (3N − 3 degrees of freedom: the total
                                              momentum is conserved; 3N for particles
                                              that exchange momentum with a lattice
                                              fluid)
    P_ab = [Σ_i m_i v_ia v_ib + Σ_pairs (r_i − r_j)_a F_ij,b] / V

(Irving–Kirkwood virial form, thesis eqs. 3.46–3.49 with the sign of a pressure,
P = −σ, every pair force, dissipative and random included, and the springs' Kramers
term; v is the peculiar velocity in flow.)  Each part is reported separately.
"""

import numpy as np


def kinetic_tensor(velocities, masses=None):
    """Σ_i m_i v_ia v_ib, (3, 3); `masses` (N,) or None for unit masses."""
    if masses is None:
        return velocities.T @ velocities
    return (masses[:, None] * velocities).T @ velocities


def temperature(kinetic, n_particles: int, momentum_conserved: bool = True):
    """k_BT from kinetic tensor(s) of shape (..., 3, 3); `momentum_conserved` False
    when the particles' total momentum is not a constant (beads in a lattice fluid)."""
    trace = np.trace(np.asarray(kinetic), axis1=-2, axis2=-1)
    return trace / (3 * (n_particles - 1 if momentum_conserved else n_particles))


def scalar_pressure(tensor):
    """p = tr(P)/3."""
    return np.trace(np.asarray(tensor), axis1=-2, axis2=-1) / 3


def step_samples(observables, state, masses=None):
    """The per-step samples a scene asked for (traced, inside the scan)."""
    samples = {}
    if "temperature" in observables or "pressure" in observables:
        samples["kinetic"] = kinetic_tensor(state.velocities, masses)
    if "pressure" in observables:
        samples["virial"] = state.virial
    return samples


def reduce_samples(
    samples: dict, n_particles: int, volume: float, momentum_conserved: bool = True
) -> dict:
    """Per-step kinetic tensors and virial parts → named time series (NumPy, host
    side); other samples (already named series, e.g. conformation) pass through.

    Series: "temperature" (`momentum_conserved` as in `temperature`);
    "pressure_tensor" (total), "pressure" (its trace / 3) and
    "pressure_tensor_part/<part>" for "kinetic" and each virial part the step recorded
    ("conservative", "dissipative", "random", "bond", ...: thesis eqs. 3.46–3.49
    with the sign of a pressure, σ = −P).
    """
    passed = ("kinetic", "virial")
    series = {name: values for name, values in samples.items() if name not in passed}
    if "kinetic" in samples:
        series["temperature"] = temperature(samples["kinetic"], n_particles, momentum_conserved)
    if "virial" in samples:
        kinetic = np.asarray(samples["kinetic"])
        series["pressure_tensor_part/kinetic"] = kinetic / volume
        total = kinetic
        for name, virial in samples["virial"].items():
            series[f"pressure_tensor_part/{name}"] = np.asarray(virial) / volume
            total = total + np.asarray(virial)
        series["pressure_tensor"] = total / volume
        series["pressure"] = scalar_pressure(series["pressure_tensor"])
    return series
