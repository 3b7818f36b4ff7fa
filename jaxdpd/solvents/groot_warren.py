"""Groot–Warren DPD thermostat: pairwise dissipative and random forces.

Thesis eqs. 2.5–2.9 (Español and Warren's fluctuation–dissipation conditions):
    F_ij^D = −γ w_D(r) (e_ij · v_ij) e_ij,     F_ij^R = σ w_R(r) θ_ij e_ij / √Δt,
    w_D = w_R²,  w_R = 1 − r/r_c,  σ² = 2 γ k_BT,
with v_ij = v_i − v_j and θ_ij a zero-mean, unit-variance variate, symmetric in
(i, j).  The 1/√Δt makes the random impulse per step σ w_R θ √Δt.
"""

import jax.numpy as jnp

from jaxdpd.engine import noise

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
        theta = draw(context.key, geometry.i, geometry.j, dtype)
        normal_velocity = geometry.relative_velocity_along_pair(context.velocities)
        return {
            "dissipative": dissipative(geometry.weight, normal_velocity, gamma_),
            "random": random(geometry.weight, theta, sigma, dt_),
        }

    return term
