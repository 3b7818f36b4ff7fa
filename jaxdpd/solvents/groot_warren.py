"""Groot–Warren DPD thermostat: pairwise dissipative and random forces.

Thesis eqs. 2.5–2.9 (Español and Warren's fluctuation–dissipation conditions):
    F_ij^D = −γ w_D(r) (e_ij · v_ij) e_ij,     F_ij^R = σ w_R(r) θ_ij e_ij / √Δt,
    w_D = w_R²,  w_R = 1 − r/r_c,  σ² = 2 γ k_BT,
with v_ij = v_i − v_j and θ_ij a zero-mean, unit-variance variate, symmetric in
(i, j).  The 1/√Δt makes the random impulse per step σ w_R θ √Δt.
"""

import math
from dataclasses import dataclass
from typing import ClassVar

import jax.numpy as jnp

from jaxdpd.engine import noise
from jaxdpd.engine.integrators import modified_velocity_verlet
from jaxdpd.scene_examples import chain_solution_example
from jaxdpd.solvents import component
from jaxdpd.validation import read_choice, read_number

NOISE_LAWS = {
    "uniform": noise.pair_uniform_unit_variance,
    "gaussian": noise.pair_gaussian,
}


def dissipative(weight, relative_normal_velocity, gamma):
    """Scalar law: magnitude of F^D = −γ w_R² (e_ij · v_ij) along e_ij.

    Args:
        weight: w_R(r) = 1 − r/r_c (0 beyond the cut-off).
        relative_normal_velocity: e_ij · (v_i − v_j), laboratory frame.
        gamma: friction coefficient γ (mass/time).
    """
    return -gamma * weight * weight * relative_normal_velocity


def random(weight, theta, sigma, dt):
    """Scalar law: magnitude of F^R = σ w_R θ_ij / √Δt along e_ij.

    Args:
        weight: w_R(r) = 1 − r/r_c (0 beyond the cut-off).
        theta: unit-variance random variate, symmetric in (i, j).
        sigma: noise amplitude σ = √(2 γ k_BT).
        dt: time step Δt.
    """
    return weight * sigma * theta / jnp.sqrt(dt)


def groot_warren_term(gamma: float, kT: float, dt: float, noise_law: str, dtype):
    """Pair term for the composed step (uses context.velocities and context.key):
    `term(geometry, context) -> {"dissipative": ..., "random": ...}` magnitudes.

    Args:
        gamma: γ; kT: k_BT; dt: Δt; noise_law: "uniform" or "gaussian".
        dtype: floating dtype of the simulation.
    """
    sigma = jnp.sqrt(jnp.asarray(2 * gamma * kT, dtype))
    gamma_ = jnp.asarray(gamma, dtype)
    dt_ = jnp.asarray(dt, dtype)
    draw = NOISE_LAWS[noise_law]

    def term(geometry, context):
        theta = draw(context.key, *geometry.identity_pairs(), dtype)
        normal_velocity = geometry.relative_velocity_along_pair(context.velocities)
        return {
            "dissipative": dissipative(geometry.weight, normal_velocity, gamma_),
            "random": random(geometry.weight, theta, sigma, dt_),
        }

    return term


@dataclass(frozen=True)
class GrootWarrenParameters(component.SolventParameters):
    """solvent.method = "dpd": k_BT, the friction γ and the law of the variates θ."""

    method: ClassVar[str] = "dpd"
    gamma: float = 4.5
    noise: str = "uniform"

    @property
    def sigma(self) -> float:
        """Random-force amplitude σ = √(2 γ k_BT) (thesis eq. 2.8)."""
        return math.sqrt(2 * self.gamma * self.kT)


class GrootWarren(component.SolventMethod):
    """Groot–Warren DPD: the thermostat is a pair term; modified velocity Verlet
    (thesis eq. 2.10) with the scene's λ.  kT > 0, gamma ≥ 0 (0 = thermostat off),
    optional sigma (must equal √(2γkT)), noise = "uniform" | "gaussian"."""

    name = "dpd"
    fields = ("gamma", "sigma", "noise")
    flows = ("shear", "planar_elongation")
    body_forces = True
    uses_neighbor_list = True
    decomposition = "forces_after_drift"
    heating_advice = (
        "above Δt ≈ 0.06 reduce integrator.dt (keep integrator.lambda near 0.5–0.65); "
        "under shear rates near 1 and above the heating hardly depends on Δt: lower the "
        "rate, or use solvent.method = 'lowe_andersen', which heats about a quarter as "
        "much (benchmarks/stability_map.py; the thesis stays at rates ≤ 0.3, §4.2.7)"
    )

    def read(self, section) -> GrootWarrenParameters:
        kT = read_number(section, "kT", "solvent", 1.0, minimum=0, exclusive_minimum=True)
        gamma = read_number(section, "gamma", "solvent", 4.5, minimum=0)
        if "sigma" in section:
            sigma = read_number(section, "sigma", "solvent", minimum=0)
            expected = math.sqrt(2 * gamma * kT)
            if not math.isclose(sigma, expected, rel_tol=1e-9, abs_tol=1e-12):
                raise ValueError(
                    f"solvent.sigma = {sigma!r}: fluctuation–dissipation requires "
                    f"σ = √(2 γ kT) = {expected:.6g}; give gamma (and kT) only, or a "
                    "consistent sigma"
                )
        noise_law = read_choice(section, "noise", "solvent", component.NOISE_LAWS, "uniform")
        return GrootWarrenParameters(kT=kT, gamma=gamma, noise=noise_law)

    def to_dict(self, parameters) -> dict:
        return {
            "method": "dpd",
            "kT": parameters.kT,
            "gamma": parameters.gamma,
            "noise": parameters.noise,
        }

    def pair_terms(self, scene, dtype) -> list:
        solvent = scene.solvent
        if not solvent.gamma > 0:
            return []
        return [
            groot_warren_term(solvent.gamma, solvent.kT, scene.integrator.dt, solvent.noise, dtype)
        ]

    def example_scene(self, precision="float64") -> dict:
        """300 particles at ρ = 3 with 15 Hookean 4-bead chains, soft repulsion a = 25."""
        return chain_solution_example(
            precision,
            {"method": "dpd", "kT": 1.0, "gamma": 4.5},
            4.0,
            pair={"a": 25.0},
            integrator={"dt": 0.04, "lambda": 0.65},
        )

    def advance(self, context):
        return velocity_verlet(context)


def velocity_verlet(context: component.StepContext):
    """Modified velocity Verlet with the scene's λ: the step of a solvent whose
    thermostat, if any, is a force."""
    scene = context.scene
    return modified_velocity_verlet(
        context.box,
        scene.integrator.dt,
        scene.integrator.lambda_,
        context.interactions,
        scene.solvent.kT,
        context.dtype,
        context.masses,
        ownership=context.ownership,
    )
