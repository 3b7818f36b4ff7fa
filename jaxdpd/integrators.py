"""Time integrators.  Each factory returns `step(state) -> state`.

`interactions(positions, velocities, state) -> (vectors, virial, pair_list, bits)` is
the composed force kernel of the scene (forces for velocity Verlet, impulses for the
Hoogerbrugge–Koelman collision); it refreshes the neighbour list itself and reports
error bits of its own (e.g. an overstretched spring).
"""

import jax
import jax.numpy as jnp

from jaxdpd import errors, noise


def _flag(state, positions, velocities, pair_list, kT, bits, masses=None):
    """OR the error bits of this step into the state's flags.

    Args:
        bits: error bits the force kernel reported.
        kT: the set temperature; a mean m v² above RUNAWAY_FACTOR · 3 kT flags a
            runaway.
        masses: (N,) particle masses, or None for unit masses.
    """
    squares = velocities * velocities
    twice_kinetic = jnp.sum(squares if masses is None else masses[:, None] * squares)
    finite = jnp.isfinite(jnp.sum(positions) + twice_kinetic)
    runaway = twice_kinetic > errors.RUNAWAY_FACTOR * 3 * kT * velocities.shape[0]
    bits = (
        jnp.where(finite, 0, errors.NON_FINITE)
        | jnp.where(runaway, errors.TEMPERATURE_RUNAWAY, 0)
        | jnp.where(pair_list.overflow, errors.NEIGHBOR_OVERFLOW, 0)
        | bits
    )
    return state.flags | bits.astype(jnp.int32)


def modified_velocity_verlet(
    box, dt: float, lambda_: float, interactions, kT: float, dtype, masses=None
):
    """Groot–Warren modified velocity Verlet (thesis eq. 2.10), a = f/m:

        r(t+Δt) = r + Δt v + ½ Δt² a(t)
        ṽ       = v + λ Δt a(t)
        f(t+Δt) = f(r(t+Δt), ṽ)
        v(t+Δt) = v + ½ Δt [a(t) + a(t+Δt)]

    λ = ½ is the usual velocity Verlet; Groot and Warren found λ ≈ 0.65 best for
    DPD at Δt = 0.04.  The pair noise of step n+1 is keyed by n+1.  `kT` is the
    temperature scale of the runaway check (see jaxdpd.errors).  `masses` is the
    (N,) array of particle masses, or None for unit masses (no division traced).
    """
    dt_ = jnp.asarray(dt, dtype)
    lam = jnp.asarray(lambda_, dtype)

    def acceleration(forces):
        return forces if masses is None else forces / masses[:, None]

    def step(state):
        accelerations = acceleration(state.forces)
        moved = state.positions + dt_ * state.velocities + (0.5 * dt_ * dt_) * accelerations
        positions, image = box.wrap(moved, state.image)
        predicted = state.velocities + (lam * dt_) * accelerations
        advanced = state.set(positions=positions, image=image, step=state.step + 1)
        new_forces, virial, pair_list, bits = interactions(positions, predicted, advanced)
        velocities = state.velocities + (0.5 * dt_) * (accelerations + acceleration(new_forces))
        return advanced.set(
            velocities=velocities,
            forces=new_forces,
            pair_list=pair_list,
            virial=virial,
            time=state.time + dt_,
            flags=_flag(state, positions, velocities, pair_list, kT, bits, masses),
        )

    return step


def collide_and_stream(box, dt: float, interactions, kT: float, dtype):
    """Hoogerbrugge–Koelman step: pair collision, then free flight over δt (unit masses).

        v_i ← v_i + Σ_j Ω_ij e_ij,     r_i ← r_i + v_i δt.

    The recorded virial is that of the collision impulses divided by δt (the mean
    force they exert over the step).
    """
    dt_ = jnp.asarray(dt, dtype)

    def step(state):
        impulses, virial, pair_list, bits = interactions(state.positions, state.velocities, state)
        velocities = state.velocities + impulses
        positions, image = box.wrap(state.positions + dt_ * velocities, state.image)
        return state.set(
            positions=positions,
            velocities=velocities,
            image=image,
            pair_list=pair_list,
            virial=virial / dt_,
            step=state.step + 1,
            time=state.time + dt_,
            flags=_flag(state, positions, velocities, pair_list, kT, bits),
        )

    return step


def mpcd_cycle(
    box,
    collision_time: float,
    substeps: int,
    monomers,
    monomer_step,
    collide,
    kT: float,
    dtype,
    masses=None,
):
    """One MPCD cycle (Mussawisade et al. 2005, §II): streaming over the collision time
    h, then a collision.

    Streaming: every particle outside the monomer range moves ballistically,
    r ← r + h v (eq. 1); the monomers [first, stop) instead take `substeps` steps of
    `monomer_step` (velocity Verlet with h_p = h/substeps under their bonded and pair
    forces) on a state that holds their rows only.  Collision: `collide(positions,
    velocities, key) -> (velocities, collisional virial)` with the key of collision
    n + 1 (`noise.step_key(seed, n + 1)`, n the step counter), so the grid shift and
    rotation axes are functions of (seed, collision index) alone.

    The recorded virial is the collisional one divided by h (the mean force over the
    cycle, as for the Hoogerbrugge–Koelman impulses) plus the monomers' force virial
    at the end of the streaming.

    Args:
        box: the box (its `wrap` moves particles across the boundaries).
        collision_time: h.
        substeps: h/h_p.
        monomers: (first, stop) index range of the monomers, or None.
        monomer_step: `step(state) -> state` over the monomer rows (None without
            monomers).
        collide: the collision.
        kT: temperature scale of the runaway check.
        dtype: floating dtype.
        masses: (N,) masses or None.
    Returns:
        `step(state) -> state`, one collision per step; time advances by h.
    """
    h = jnp.asarray(collision_time, dtype)

    def stream_monomers(state, first, stop):
        rows = slice(first, stop)
        sub = state.set(
            positions=state.positions[rows],
            velocities=state.velocities[rows],
            forces=state.forces[rows],
            image=state.image[rows],
            species=state.species[rows],
        )
        return jax.lax.fori_loop(0, substeps, lambda _, s: monomer_step(s), sub)

    def step(state):
        positions, image = box.wrap(state.positions + h * state.velocities, state.image)
        velocities, forces = state.velocities, state.forces
        virial, pair_list, bits = jnp.zeros((3, 3), dtype), state.pair_list, jnp.int32(0)
        if monomers is not None:
            first, stop = monomers
            moved = stream_monomers(state, first, stop)
            positions = positions.at[first:stop].set(moved.positions)
            image = image.at[first:stop].set(moved.image)
            velocities = velocities.at[first:stop].set(moved.velocities)
            forces = forces.at[first:stop].set(moved.forces)
            virial, pair_list, bits = moved.virial, moved.pair_list, moved.flags
        collision = state.step + 1
        velocities, collision_virial = collide(
            positions, velocities, noise.step_key(state.seed, collision)
        )
        return state.set(
            positions=positions,
            velocities=velocities,
            forces=forces,
            image=image,
            pair_list=pair_list,
            virial=virial + collision_virial / h,
            step=collision,
            time=state.time + h,
            flags=_flag(state, positions, velocities, pair_list, kT, bits, masses),
        )

    return step
