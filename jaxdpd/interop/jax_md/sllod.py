"""SLLOD streaming in a Lees–Edwards or Kraynik–Reinelt box, as a jax-md simulator.

jax-md's integrators (`jax_md.simulate`) move particles in a fixed or barostatted
box; none imposes a homogeneous flow.  This one integrates the SLLOD equations
(thesis eqs. 3.42–3.43, jaxdpd.geometry.flows)

    ṙ = c + L (r − r0),        ċ = F/m − L c,

for the peculiar velocities c, with the box clock (Lees–Edwards offset, Kraynik–
Reinelt strain) in the state and advanced with every step, so the force function sees
the box as it is at each position.  The step is jaxdpd's modified velocity Verlet
(Groot & Warren, J. Chem. Phys. 107, 4423 (1997), eq. 18): streaming in the position
update, a trapezoidal −L c, and a predicted velocity c + λ Δt ċ handed to forces that
depend on velocity (DPD).  Optionally a Langevin thermostat acts on the peculiar
velocities after each step (the exact Ornstein–Uhlenbeck update c ← e^{−γΔt} c +
√(k_BT/m (1 − e^{−2γΔt})) ξ), which for a homogeneous flow is the usual SLLOD
thermostat on the peculiar (profile-unbiased) velocities.  In flow the round-off of
the total peculiar momentum is removed after each step (it grows as e^{ε̇t} along a
compressing axis; Todd & Daivis, Comput. Phys. Commun. 117, 191 (1999)).
"""

import jax
import jax.numpy as jnp
from jax_md import dataclasses as jmd_dataclasses
from jax_md import quantity

from jaxdpd.geometry import flows


@jmd_dataclasses.dataclass
class SLLODState:
    """State of the SLLOD simulator.

    Attributes:
        position: (N, 3) wrapped positions.
        velocity: (N, 3) peculiar velocities c = v − u(r).
        force: (N, 3) forces at `position`.
        mass: scalar or (N,) masses.
        box: the jaxdpd box state (None for a periodic box at rest).
        step: int32 steps taken (keys the noise of velocity-dependent forces).
        rng: PRNG key of the Langevin thermostat.
    """

    position: jnp.ndarray
    velocity: jnp.ndarray
    force: jnp.ndarray
    mass: jnp.ndarray
    box: object
    step: jnp.ndarray
    rng: jnp.ndarray


def sllod(
    energy_or_force_fn,
    box,
    dt: float,
    kT: float | None = None,
    gamma: float = 0.0,
    lambda_: float = 0.5,
    velocity_dependent: bool = False,
):
    """`(init_fn, apply_fn)` for SLLOD streaming in `box` (see the module docstring).

        init_fn(key, R, velocity=None, mass=1.0, box=None, **kwargs) -> SLLODState
        apply_fn(state, **kwargs) -> SLLODState

    The force function is called as `force_fn(R, box=box_state, **kwargs)` (jax-md
    energy functions built on jaxdpd.interop.jax_md.space read `box=`), plus
    `velocity=` (predicted peculiar velocities) and `step=` when `velocity_dependent`.
    Without `velocity`, init_fn draws Maxwell–Boltzmann peculiar velocities at `kT`
    with zero total momentum; without `box`, it starts from `box.initial_state`.

    Args:
        energy_or_force_fn: a jax-md energy or force function of positions.
        box: a jaxdpd box (jaxdpd.geometry.boxes); its flow rate is in the box state.
        dt: time step.
        kT: temperature of the Langevin thermostat and of the initial velocities.
        gamma: Langevin friction rate on the peculiar velocities (0: none).
        lambda_: the velocity predictor of Groot–Warren (½: velocity Verlet).
        velocity_dependent: pass `velocity=` and `step=` to the force function.
    """
    force_fn = quantity.canonicalize_force(energy_or_force_fn)
    if gamma and kT is None:
        raise ValueError(f"gamma = {gamma}: a Langevin thermostat needs kT")
    static_box, step_size = box, dt  # `box=` and `dt` below are per-call values

    def forces(position, box_state, velocity, step, kwargs):
        if velocity_dependent:
            kwargs = {**kwargs, "velocity": velocity, "step": step}
        return force_fn(position, box=box_state, **kwargs)

    def init_fn(key, R, velocity=None, mass=1.0, box=None, **kwargs):
        box_state = box if box is not None else static_box.initial_state(R.dtype)
        mass = jnp.asarray(mass, R.dtype)
        key, draw = jax.random.split(key)
        if velocity is None:
            if kT is None:
                raise ValueError("init_fn: give velocity= or build the simulator with kT")
            velocity = jax.random.normal(draw, R.shape, R.dtype) * jnp.sqrt(kT / _rows(mass))
            velocity = velocity - _centre_of_mass_velocity(velocity, _masses(mass))
        step = jnp.asarray(0, jnp.int32)
        force = forces(R, box_state, velocity, step, kwargs)
        return SLLODState(R, velocity, force, mass, box_state, step, key)

    def apply_fn(state, **kwargs):
        dtype = state.position.dtype
        dt = jnp.asarray(step_size, dtype)
        per_particle = _rows(state.mass)
        bound = static_box.bind(state.box)
        acceleration = state.force / per_particle
        drift = flows.drift_velocity(bound, state.position, state.velocity)
        curvature = flows.streaming_curvature(bound, state.position)
        position_acceleration = acceleration if curvature is None else acceleration + curvature
        moved = state.position + dt * drift + (0.5 * dt * dt) * position_acceleration
        box_state = static_box.advance(state.box, None, dt)
        new_bound = static_box.bind(box_state)
        position, _ = new_bound.wrap(moved, jnp.zeros(moved.shape, jnp.int32))
        drag = flows.sllod_drag(bound, state.velocity)
        rate = acceleration if drag is None else acceleration + drag
        predicted = state.velocity + (lambda_ * dt) * rate
        step = state.step + 1
        force = forces(position, box_state, predicted, step, kwargs)
        right_hand_side = state.velocity + (0.5 * dt) * (rate + force / per_particle)
        velocity = flows.implicit_sllod_velocity(new_bound, right_hand_side, dt)
        rng = state.rng
        if gamma:
            rng, draw = jax.random.split(rng)
            decay = jnp.exp(jnp.asarray(-gamma * step_size, dtype))
            spread = jnp.sqrt(kT * (1 - decay * decay) / per_particle)
            velocity = decay * velocity + spread * jax.random.normal(draw, velocity.shape, dtype)
        velocity = flows.remove_momentum_drift(new_bound, velocity, _masses(state.mass))
        return state.set(
            position=position, velocity=velocity, force=force, box=box_state, step=step, rng=rng
        )

    return init_fn, apply_fn


def _rows(mass):
    """Masses broadcastable against (N, 3) vectors."""
    return mass[:, None] if jnp.ndim(mass) else mass


def _masses(mass):
    """(N,) masses for momentum sums, or None for one scalar mass (unit weights)."""
    return mass if jnp.ndim(mass) else None


def _centre_of_mass_velocity(velocity, masses):
    """Σ m c / Σ m (the mean for equal masses)."""
    if masses is None:
        return jnp.mean(velocity, axis=0)
    return (masses @ velocity) / jnp.sum(masses)
