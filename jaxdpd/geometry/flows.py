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
velocities (jaxdpd.forces.pair_sums.PairGeometry.relative_velocity_along_pair), the
temperature is measured from c.

For planar elongation (diagonal L, thesis eq. 5.12) L² ≠ 0 and the streaming map
1 + Δt L + ½ Δt² L² of the position update differs from the box's exact e^{Δt L} by
(ε̇Δt)³/6 per step: the particles stream at ε̇ (1 − (ε̇Δt)²/6) while the lattice
deforms at ε̇, a relative 7e-5 at ε̇Δt = 0.02, which a homogeneous peculiar flow
makes up; the velocity update is Crank–Nicolson for ċ = −L c, also second order.

The total peculiar momentum Σ m c obeys d/dt Σ m c = Σ F − L Σ m c = −L Σ m c, so it
stays zero, but along a compressing axis (L_xx = −ε̇) its round-off grows as
e^{ε̇ t}: from 1e-7 in float32 it reaches thermal size within a strain of ~15 (Todd
& Daivis, Comput. Phys. Commun. 117, 191 (1999)).  `remove_momentum_drift` takes it
out after every step in flow (at round-off level in shear too).
"""

import jax.numpy as jnp

# The box-state field holding the rate of each flow kind (scene [flow] kind).
RATE_FIELDS = {"shear": "shear_rate", "planar_elongation": "elongation_rate"}

# Flow kinds whose gradient has a compressing eigenvalue, so the round-off of Σ m c
# grows as e^{ε̇ t} (module docstring): a step that conserves momentum and does not
# otherwise call `remove_momentum_drift` (MPCD) must call it there.  In shear
# (L² = 0) it grows only linearly.
EXPONENTIAL_MOMENTUM_DRIFT = frozenset({"planar_elongation"})


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


def remove_momentum_drift(bound_box, velocities, masses=None, ownership=None):
    """Peculiar velocities with zero total momentum: c − Σ m c / Σ m (see the module
    docstring); unchanged (nothing traced) in a box at rest.

    Args:
        velocities: (N, 3) peculiar velocities.
        masses: (N,) particle masses, or None for unit masses.
        ownership: the rows a domain owns and the sum over domains
            (jaxdpd.engine.ownership) in a decomposed run, else None.
    """
    if bound_box.velocity_gradient is None:
        return velocities
    if ownership is not None:
        weights = jnp.ones(velocities.shape[:1], velocities.dtype) if masses is None else masses
        momentum = ownership.system_sum(weights[:, None] * velocities)
        return velocities - momentum / ownership.system_sum(weights)
    if masses is None:
        return velocities - jnp.mean(velocities, axis=0)
    return velocities - (masses @ velocities) / jnp.sum(masses)


def set_flow_rate(state, flow_kind: str, rate):
    """The state with its box's flow rate set (between chunks: start-up, cessation).

    Args:
        state: a SimState, or a batch of them (jaxdpd.run.ensemble).
        flow_kind: the scene's flow.kind ("shear": γ̇, "planar_elongation": ε̇).
        rate: the new rate (1/time): a scalar, or one per replica of a batch.
    """
    field = RATE_FIELDS[flow_kind]
    current = getattr(state.box_state, field)
    rate = jnp.broadcast_to(jnp.asarray(rate, current.dtype), current.shape)
    return state.set(box_state=state.box_state.set(**{field: rate}))
