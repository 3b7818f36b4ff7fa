"""Homogeneous flows imposed with the SLLOD equations of motion (thesis eqs. 3.42–3.43).

With peculiar velocities c = v − u(r), u(r) = L (r − r0) the streaming velocity of a
flowing box (velocity gradient L_ab = ∂u_a/∂r_b, r0 the box centre) and unit or
per-particle masses:

    ṙ = c + L (r − r0),        ċ = F/m − L c.

Differentiating once more, r̈ = F/m + L² (r − r0): the SLLOD terms cancel in the
acceleration of the position (for shear L² = 0), so positions advance as in the
laboratory frame.  Velocity Verlet with a trapezoidal SLLOD term gives

    r(t+Δt) = r + Δt (c + u(r)) + ½ Δt² (F/m + L u(r))
    (1 + ½ Δt L') c(t+Δt) = (1 − ½ Δt L) c + ½ Δt [F/m + F'/m],

second order like the force part, exact for free streaming, with L' the gradient
at t + Δt (time-dependent flows).  The thermostat sees laboratory relative
velocities (jaxdpd.pairwise.PairGeometry.relative_velocity_along_pair), the
temperature is measured from c.
"""

import jax.numpy as jnp


def drift_velocity(bound_box, positions, velocities):
    """dr/dt = c + u(r): peculiar plus streaming velocity, (N, 3)."""
    if bound_box.velocity_gradient is None:
        return velocities
    return velocities + bound_box.streaming_velocity(positions)


def streaming_curvature(bound_box, positions):
    """L u(r) = L² (r − r0), the streaming part of r̈ (zero for shear); None at rest."""
    gradient = bound_box.velocity_gradient
    if gradient is None:
        return None
    return bound_box.streaming_velocity(positions) @ gradient.T


def sllod_drag(bound_box, velocities):
    """−L c, the SLLOD term of ċ (thesis eq. 3.43); None at rest."""
    gradient = bound_box.velocity_gradient
    if gradient is None:
        return None
    return -(velocities @ gradient.T)


def implicit_sllod_velocity(bound_box, right_hand_side, dt):
    """Solve (1 + ½ Δt L') c' = rhs for the new peculiar velocities c' (N, 3).

    For shear L'² = 0 and the inverse is exactly 1 − ½ Δt L'.
    """
    gradient = bound_box.velocity_gradient
    if gradient is None:
        return right_hand_side
    system = jnp.eye(3, dtype=right_hand_side.dtype) + 0.5 * dt * gradient
    return right_hand_side @ jnp.linalg.inv(system).T
