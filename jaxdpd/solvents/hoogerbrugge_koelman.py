"""The original DPD update of Hoogerbrugge and Koelman (Europhys. Lett. 19, 155 (1992)).

One step is a collision followed by free propagation over δt:
    p_i ← p_i + Σ_j Ω_ij e_ij,
    Ω_ij = W(r_ij) [Π0 + δΠ_ij − ω (p_i − p_j)·e_ij],
    W(r) = 3 (1 − r/r_c) / (π n r_c³)   for r < r_c (normalised: n ∫ W d³r = 1),
    r_i ← r_i + p_i δt / m,
with e_ij the unit vector from j to i, n the number density and δΠ_ij uniform on
[−Δ, Δ] and symmetric in (i, j).  Defaults Π0 = 1/3, ω = 4/3, Δ = 1/3, δt = 1.

The collision is handed to the integrator as the mean force Ω_ij/δt over the step,
so that it adds to other forces (springs, body forces: Schlijper, Hoogerbrugge &
Manke, J. Rheol. 39, 567 (1995), apply them as impulses F δt in the same update)
and the integrator turns their sum into the impulse δt Σ F.  The collision impulse
Ω_ij itself does not depend on δt: δt changes the model, not its accuracy.
"""

import jax.numpy as jnp

from jaxdpd.engine import noise


def collision_weight(weight, density, cutoff):
    """W(r) = 3 (1 − r/r_c) / (π n r_c³), given the DPD weight 1 − r/r_c."""
    return 3 * weight / (jnp.pi * density * cutoff**3)


def collision_magnitude(w, relative_normal_momentum, delta_pi, pi0, omega):
    """Scalar law Ω_ij = W [Π0 + δΠ_ij − ω (p_i − p_j)·e_ij]."""
    return w * (pi0 + delta_pi - omega * relative_normal_momentum)


def hoogerbrugge_koelman_term(density, cutoff, pi0, omega, delta_pi_half_width, mass, dt, dtype):
    """Collision term for the composed step (context.velocities, context.key):
    `term(geometry, context) -> {"collision": Ω_ij/δt}`, the pair's mean force over
    the step δt (module docstring).

    Args:
        density: n of W(r), particles per r_c³.
        cutoff: r_c.
        pi0, omega, delta_pi_half_width: Π0, ω, Δ.
        mass: particle mass m (the relative momentum is m (v_i − v_j)·e_ij).
        dt: δt.
        dtype: floating dtype.
    """
    pi0_, omega_ = jnp.asarray(pi0, dtype), jnp.asarray(omega, dtype)
    width = jnp.asarray(delta_pi_half_width, dtype)
    dt_ = jnp.asarray(dt, dtype)

    def term(geometry, context):
        delta_pi = noise.pair_uniform(context.key, geometry.i, geometry.j, -width, width, dtype)
        momentum = geometry.relative_velocity_along_pair(context.velocities) * mass
        w = collision_weight(geometry.weight, density, cutoff)
        return {"collision": collision_magnitude(w, momentum, delta_pi, pi0_, omega_) / dt_}

    return term
