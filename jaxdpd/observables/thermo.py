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

from jaxdpd.analysis.elongation import elongational_material_functions
from jaxdpd.analysis.rheology import normal_stress_differences, shear_rheology
from jaxdpd.dyadic import dyadic_square
from jaxdpd.observables.component import (
    Observable,
    long_enough,
    steady_elongation_rate,
    steady_shear_rate,
    summary_row,
)


def kinetic_tensor(velocities, masses=None):
    """Σ_i m_i v_ia v_ib, (3, 3); `masses` (N,) or None for unit masses."""
    return dyadic_square(velocities, masses)


def system_kinetic_tensor(ownership, state):
    """Σ_i v_i v_iᵀ over a decomposed system's particles (unit masses), from one
    device's rows (jaxdpd.engine.ownership): its owned rows weighted 1, the others 0."""
    weights = ownership.weights(state.velocities.dtype)
    return ownership.across_devices(kinetic_tensor(state.velocities, weights))


def temperature(kinetic, n_particles: int, momentum_conserved: bool = True):
    """k_BT from kinetic tensor(s) of shape (..., 3, 3); `momentum_conserved` False
    when the particles' total momentum is not a constant (beads in a lattice fluid)."""
    trace = np.trace(np.asarray(kinetic), axis1=-2, axis2=-1)
    return trace / (3 * (n_particles - 1 if momentum_conserved else n_particles))


def scalar_pressure(tensor):
    """p = tr(P)/3."""
    return np.trace(np.asarray(tensor), axis1=-2, axis2=-1) / 3


def temperature_series(samples: dict, scene) -> dict:
    """ "temperature" from the per-step kinetic tensors (momentum conserved as the
    scene's particles conserve it)."""
    kinetic = samples["kinetic"]
    return {
        "temperature": temperature(kinetic, scene.n_particles, scene.particle_momentum_conserved)
    }


def pressure_series(samples: dict, scene) -> dict:
    """Per-step kinetic tensors and virial parts → "pressure_tensor" (total),
    "pressure" (its trace / 3) and "pressure_tensor_part/<part>" for "kinetic" and each
    virial part the step recorded ("conservative", "dissipative", "random", "bond",
    ...: thesis eqs. 3.46–3.49 with the sign of a pressure, σ = −P)."""
    volume = scene.volume
    kinetic = np.asarray(samples["kinetic"])
    series = {"pressure_tensor_part/kinetic": kinetic / volume}
    total = kinetic
    for name, virial in samples["virial"].items():
        series[f"pressure_tensor_part/{name}"] = np.asarray(virial) / volume
        total = total + np.asarray(virial)
    series["pressure_tensor"] = total / volume
    series["pressure"] = scalar_pressure(series["pressure_tensor"])
    return series


def polymer_name(name: str) -> str:
    """ "eta1_polymer" of jaxdpd.analysis.elongation → "polymer/eta1", the summary's
    name for a polymer part (as "polymer/viscosity" in shear)."""
    return f"polymer/{name.removesuffix('_polymer')}" if name.endswith("_polymer") else name


class Temperature(Observable):
    """The kinetic temperature k_BT per step (from the kinetic tensor)."""

    name = "temperature"
    consumes = ("kinetic",)
    decomposes = True
    units = {"temperature": "k_BT"}

    def sampler(self, context):
        masses = context.masses

        def sample(previous, state):
            return state, {"kinetic": kinetic_tensor(state.velocities, masses)}

        return sample

    def domain_sampler(self, context):
        return lambda ownership, state: {"kinetic": system_kinetic_tensor(ownership, state)}

    def reduce(self, samples, scene):
        return temperature_series(samples, scene)


class Pressure(Observable):
    """The virial pressure tensor per step, total and by part; under steady shear the
    material functions in the run summary (jaxdpd.analysis.rheology)."""

    name = "pressure"
    needs_virial = True
    consumes = ("kinetic", "virial")
    decomposes = True
    units = {
        "pressure": "k_BT/r_c^3",
        "pressure_tensor": "k_BT/r_c^3",
        "pressure_tensor_part/": "k_BT/r_c^3",
    }

    def sampler(self, context):
        masses = context.masses

        def sample(previous, state):
            return state, {
                "kinetic": kinetic_tensor(state.velocities, masses),
                "virial": state.virial,
            }

        return sample

    def domain_sampler(self, context):
        def sample(ownership, state):
            return {
                "kinetic": system_kinetic_tensor(ownership, state),
                "virial": {
                    part: ownership.across_devices(share) for part, share in state.virial.items()
                },
            }

        return sample

    def reduce(self, samples, scene):
        return pressure_series(samples, scene)

    def memory(self, scene, itemsize):
        return {"run.chunk": 9 * scene.run.chunk * itemsize}  # a tensor per step

    def summary_rows(self, scene, series, n_blocks):
        """Under steady shear: N1, N2 and η, Ψ1, Ψ2 of the fluid, the polymer and each
        part; in planar elongation: η̄1, η̄2 of the fluid and the polymer."""
        if not long_enough(series, "pressure_tensor", n_blocks):
            return {}
        shear, elongation = steady_shear_rate(scene), steady_elongation_rate(scene)
        if shear is not None:
            rows = normal_stress_differences(series["pressure_tensor"], n_blocks)
            rows |= shear_rheology(series, shear, n_blocks)
        elif elongation is not None:
            functions = elongational_material_functions(series, elongation, n_blocks)
            rows = {polymer_name(name): value for name, value in functions.items()}
        else:
            return {}
        return {name: summary_row(estimate) for name, estimate in rows.items()}
