"""Time integrators.  Each factory returns `step(state) -> state`.

`interactions(positions, velocities, state) -> (vectors, virial, state, bits)` is
the composed force kernel of the scene (forces; the Hoogerbrugge–Koelman collision
enters as its mean force over the step); it refreshes the neighbour lists itself (it returns
`state` with them refreshed: the pair list, and the spring-pair list where there is
one) and reports error bits of its own (e.g. an overstretched spring, a spring-pair
list overflow).
"""

import jax
import jax.numpy as jnp

from jaxdpd.dyadic import dyadic_square, dyadic_sum
from jaxdpd.engine import errors, noise
from jaxdpd.geometry import flows


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
        jnp.where(finite, 0, errors.StepError.NON_FINITE)
        | jnp.where(runaway, errors.StepError.TEMPERATURE_RUNAWAY, 0)
        | jnp.where(pair_list.overflow, errors.StepError.NEIGHBOR_OVERFLOW, 0)
        | bits
    )
    return state.flags | bits.astype(jnp.int32)


def modified_velocity_verlet(
    box,
    dt: float,
    lambda_: float,
    interactions,
    kT: float,
    dtype,
    masses=None,
    closed_system: bool = True,
    ownership=None,
):
    """Groot–Warren modified velocity Verlet (thesis eq. 2.10), a = f/m:

        r(t+Δt) = r + Δt v + ½ Δt² a(t)
        ṽ       = v + λ Δt a(t)
        f(t+Δt) = f(r(t+Δt), ṽ)
        v(t+Δt) = v + ½ Δt [a(t) + a(t+Δt)]

    λ = ½ is the usual velocity Verlet; Groot and Warren found λ ≈ 0.65 best for
    DPD at Δt = 0.04.  The pair noise of step n+1 is keyed by n+1.  `kT` is the
    temperature scale of the runaway check (see jaxdpd.engine.errors).  `masses` is the
    (N,) array of particle masses, or None for unit masses (no division traced).

    In a flowing box (shear, elongation) v is the peculiar velocity and the SLLOD
    terms of jaxdpd.geometry.flows are added: streaming in the position update, −L c in
    the accelerations (also in the predicted ṽ), trapezoidal in the velocity update,
    then, if `closed_system` (the particles stepped are all there are), the
    round-off of the total peculiar momentum is removed (it grows exponentially in
    elongation); the box state advances with the step.  MPCD monomers are not a
    closed system (they exchange momentum with the solvent in the collisions).  A box at
    rest traces none of this.  In a decomposed run `ownership`
    (jaxdpd.engine.ownership) says which rows the system's momentum counts.
    """
    dt_ = jnp.asarray(dt, dtype)
    lam = jnp.asarray(lambda_, dtype)

    def acceleration(forces):
        return forces if masses is None else forces / masses[:, None]

    def step(state):
        bound = box.bind(state.box_state)
        accelerations = acceleration(state.forces)
        displacement_acceleration = accelerations
        curvature = flows.streaming_curvature(bound, state.positions)
        if curvature is not None:
            displacement_acceleration = accelerations + curvature
        drift = flows.drift_velocity(bound, state.positions, state.velocities)
        moved = state.positions + dt_ * drift + (0.5 * dt_ * dt_) * displacement_acceleration
        box_state = box.advance(state.box_state, state.time, dt_)
        new_bound = box.bind(box_state)
        image = box.carry_images(state.image, state.box_state, box_state)
        positions, image = new_bound.wrap(moved, image)
        rate_of_change = accelerations
        drag = flows.sllod_drag(bound, state.velocities)
        if drag is not None:
            rate_of_change = accelerations + drag
        predicted = state.velocities + (lam * dt_) * rate_of_change
        advanced = state.set(
            positions=positions, image=image, box_state=box_state, step=state.step + 1
        )
        new_forces, virial, advanced, bits = interactions(positions, predicted, advanced)
        right_hand_side = state.velocities + (0.5 * dt_) * (
            rate_of_change + acceleration(new_forces)
        )
        velocities = flows.implicit_sllod_velocity(new_bound, right_hand_side, dt_)
        if closed_system:
            velocities = flows.remove_momentum_drift(new_bound, velocities, masses, ownership)
        return advanced.set(
            velocities=velocities,
            forces=new_forces,
            virial=virial,
            time=state.time + dt_,
            flags=_flag(state, positions, velocities, advanced.pair_list, kT, bits, masses),
        )

    return step


def thermalized_velocity_verlet(
    box,
    dt: float,
    interactions,
    thermalize,
    kT: float,
    dtype,
    masses=None,
    with_virial=False,
    ownership=None,
):
    """Velocity Verlet followed by a pair thermalisation: Lowe–Andersen DPD (Lowe,
    Europhys. Lett. 47, 145 (1999); thesis table 2.1), with a = f/m:

        v(t+½Δt) = v(t) + ½ Δt a(t)
        r(t+Δt)  = r(t) + Δt v(t+½Δt)
        f(t+Δt)  = f(r(t+Δt))                 (velocity-independent forces)
        ṽ        = v(t+½Δt) + ½ Δt a(t+Δt)
        v(t+Δt)  = thermalize(r(t+Δt), ṽ)     (pairs within r_T at r(t+Δt))

    The first four lines are `modified_velocity_verlet` at λ = ½ (λ plays no role
    without velocity-dependent forces), SLLOD terms included in a flowing box.
    Table 2.1 is the same sequence read as a leapfrog: its steps 1–3 (half kick,
    thermalise, half kick, both kicks with F(t)) turn v(t−½Δt) into v(t+½Δt) with the
    thermalisation acting on the on-step velocity v(t) at r(t), which is the velocity
    stored here.  Thermalising the half-step velocity instead (half kick, thermalise,
    drift, force, half kick) is a different splitting: its on-step kinetic temperature
    is biased by O(Δt²) (+1.3 % at Δt = 0.01, ΓΔt = 1, ρ = 3, a = 25, measured).

    Args:
        box: the box (see jaxdpd.geometry.boxes).
        dt: Δt.
        interactions: the composed force kernel (see the module docstring).
        thermalize: `thermalize(state, velocities) -> (velocities, record)`, given the
            state at the end of the step (its positions, box state, refreshed pair
            list and step counter); the record is kept in `state.solvent_state`.
        kT: temperature scale of the runaway check (see jaxdpd.engine.errors).
        dtype: floating dtype.
        masses: (N,) particle masses, or None for unit masses.
        with_virial: record.impulse_virial (3, 3) becomes the virial part "impulse"
            (thesis eq. 3.47, third term).
        ownership: as in `modified_velocity_verlet` (None: one device).
    """
    verlet = modified_velocity_verlet(
        box, dt, 0.5, interactions, kT, dtype, masses, ownership=ownership
    )

    def step(state):
        advanced = verlet(state)
        velocities, record = thermalize(advanced, advanced.velocities)
        virial = advanced.virial
        if with_virial:
            virial = {**virial, "impulse": record.impulse_virial}
        return advanced.set(velocities=velocities, virial=virial, solvent_state=record)

    return step


def free_flight(bound, new_bound, positions, velocities, duration):
    """Free flight over h of force-free particles in a box going from `bound` to
    `new_bound`: SLLOD without forces (jaxdpd.geometry.flows), r ← r + h (c + u(r)) +
    ½ h² L u(r) and (1 + ½ h L') c' = (1 − ½ h L) c, exact in shear (c' = c − h L c,
    the laboratory velocity kept), second order in elongation.  At rest r ← r + h v.

    Returns:
        (unwrapped positions, peculiar velocities), (N, 3) each.
    """
    moved = positions + duration * flows.drift_velocity(bound, positions, velocities)
    curvature = flows.streaming_curvature(bound, positions)
    if curvature is not None:
        moved = moved + (0.5 * duration * duration) * curvature
    drag = flows.sllod_drag(bound, velocities)
    if drag is None:
        return moved, velocities
    return moved, flows.implicit_sllod_velocity(
        new_bound, velocities + 0.5 * duration * drag, duration
    )


def collide_and_stream(
    box, dt: float, interactions, kT: float, dtype, with_virial=False, ownership=None
):
    """Hoogerbrugge–Koelman step: pair collision, then free flight over δt (unit masses).

        c_i ← c_i + δt F_i,     then `free_flight` over δt,

    with F_i the sum of the collision's mean force Σ_j Ω_ij e_ij/δt
    (jaxdpd.solvents.hoogerbrugge_koelman; in a flowing box it reads the laboratory
    relative velocities, thesis eq. 3.18) and of the springs' and body forces,
    which Schlijper, Hoogerbrugge & Manke (J. Rheol. 39, 567 (1995)) apply as the
    impulses F δt in the same update.  At rest c = v and the flight is r ← r + v δt.
    In a flowing box c is the peculiar velocity, the box state advances with the
    flight and the round-off of Σ c is removed (as in `modified_velocity_verlet`).

    Recorded virial parts: those of the forces, and (`with_virial`, in flow)
    "streaming", the flight average of the kinetic stress minus its value at the end
    of the step, where the observables sample it (`free_flight_stress`).  `kT` is
    the temperature scale of the runaway check: the fluid's expected temperature
    (solvent.initial_kT), not a set one.  In a decomposed run `ownership`
    (jaxdpd.engine.ownership) says which rows the momentum and the streaming part sum.
    """
    dt_ = jnp.asarray(dt, dtype)

    def step(state):
        forces, virial, refreshed, bits = interactions(state.positions, state.velocities, state)
        collided = state.velocities + dt_ * forces
        bound = box.bind(state.box_state)
        box_state = box.advance(state.box_state, state.time, dt_)
        new_bound = box.bind(box_state)
        moved, velocities = free_flight(bound, new_bound, state.positions, collided, dt_)
        image = box.carry_images(state.image, state.box_state, box_state)
        positions, image = new_bound.wrap(moved, image)
        velocities = flows.remove_momentum_drift(new_bound, velocities, ownership=ownership)
        if with_virial and bound.velocity_gradient is not None:
            if ownership is None:
                weights = jnp.ones(collided.shape[0], dtype)
                before, after = collided, velocities
            else:
                weights = ownership.weights(dtype)
                before, after = weights[:, None] * collided, weights[:, None] * velocities
            virial = {
                **virial,
                "streaming": free_flight_stress(bound.velocity_gradient, collided, weights, dt_)
                + dyadic_sum(before, collided)
                - dyadic_sum(after, velocities),
            }
        return refreshed.set(
            positions=positions,
            velocities=velocities,
            image=image,
            virial=virial,
            box_state=box_state,
            step=state.step + 1,
            time=state.time + dt_,
            flags=_flag(state, positions, velocities, refreshed.pair_list, kT, bits),
        )

    return step


def free_flight_stress(gradient, velocities, weights, duration):
    """Σ_i w_i [⟨c c^T⟩_flight − c c^T]: how the peculiar momentum flux averaged over a
    free flight of `duration` differs from its value at the start.

    In a flow of gradient L a free particle keeps its laboratory velocity, so its
    peculiar velocity drifts, c(t) = c − t L c (jaxdpd.geometry.flows), and the kinetic stress
    it carries, time-averaged over the flight h, is
    ⟨c c^T⟩ = c c^T − (h/2)(L c c^T + c c^T L^T) + (h²/3) L c c^T L^T.  For MPCD the
    correction is of the order of the kinetic stress itself (in shear its xy part,
    −(h/2) γ̇ ρ k_BT per volume, is the −½ of η_kin in Mussawisade et al. eq. 6).

    Args:
        gradient: (3, 3) velocity gradient L.
        velocities: (N, 3) peculiar velocities at the start of the flight.
        weights: (N,) masses of the particles in free flight (0 for the others).
        duration: h.
    Returns:
        (3, 3) tensor, added to the kinetic one as the virial part "streaming".
    """
    dyad = dyadic_square(velocities, weights)  # Σ w c c^T
    drifted = gradient @ dyad
    return -0.5 * duration * (drifted + drifted.T) + (duration**2 / 3) * drifted @ gradient.T


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
    with_virial: bool = False,
    closed_system: bool = True,
):
    """One MPCD cycle (Mussawisade et al. 2005, §II): streaming over the collision time
    h, then a collision.

    Streaming: every particle outside the monomer range moves ballistically,
    r ← r + h v (eq. 1); in a sheared box v = c + u(r) and the peculiar velocity
    becomes c − h L v (SLLOD without forces, exact for free flight; jaxdpd.geometry.flows).
    The monomers [first, stop) instead take `substeps` steps of `monomer_step`
    (velocity Verlet with h_p = h/substeps under their bonded and pair forces) on a
    state that holds their rows only.  Collision: `collide(bound box, positions,
    velocities, key) -> (velocities, collisional virial or None)` with the key of
    collision n + 1 (`noise.step_key(seed, n + 1)`, n the step counter), so the grid
    shift and rotation axes are functions of (seed, collision index) alone.

    Recorded virial parts (`with_virial`): the monomers' force parts at the end of
    the streaming; "collision", the collision's virial divided by h (the mean force
    over the cycle, as for the Hoogerbrugge–Koelman impulses); in a flowing box
    "streaming", the free-flight drift of the solvent's kinetic stress
    (`free_flight_stress`; the monomers' kinetic stress is sampled at the collision).
    In planar elongation, and in oscillatory shear with monomers, the drift of the total
    peculiar momentum is removed after the collision if `closed_system` (the collision
    conserves momentum; not the Rouse variant, whose bath does not).

    Args:
        box: the static box (bound to the state's box_state; its `wrap` moves
            particles across the boundaries).
        collision_time: h.
        substeps: h/h_p.
        monomers: (first, stop) index range of the monomers, or None.
        monomer_step: `step(state) -> state` over the monomer rows (None without
            monomers).
        collide: the collision.
        kT: temperature scale of the runaway check.
        dtype: floating dtype.
        masses: (N,) masses or None.
        with_virial: record the virial parts.
        closed_system: the collision conserves the total momentum.
    Returns:
        `step(state) -> state`, one collision per step; time advances by h.
    """
    h = jnp.asarray(collision_time, dtype)
    # The round-off of Σ m c grows exponentially in elongation; in oscillatory shear the
    # solvent's flight (γ̇ at both ends of h) and the monomers' sub-steps sample γ̇(t) at
    # different times, so their SLLOD drags differ by O(h² d²γ̇/dt²) and Σ m c drifts.
    oscillating = getattr(box, "oscillation_frequency", None) is not None
    remove_drift = closed_system and (
        box.flow_kind in flows.EXPONENTIAL_MOMENTUM_DRIFT or (oscillating and monomers is not None)
    )

    def stream_monomers(state, first, stop):
        rows = slice(first, stop)
        sub = state.set(
            positions=state.positions[rows],
            velocities=state.velocities[rows],
            forces=state.forces[rows],
            image=state.image[rows],
            species=state.species[rows],
            virial={},
        )
        # The loop carries the virial parts the force kernel records (zeros at first).
        parts = jax.eval_shape(monomer_step, sub).virial
        sub = sub.set(virial=jax.tree.map(lambda w: jnp.zeros(w.shape, w.dtype), parts))
        return jax.lax.fori_loop(0, substeps, lambda _, s: monomer_step(s), sub)

    def free_weights(state):
        """Masses of the particles in free flight (zero for the monomers)."""
        weights = jnp.ones(state.velocities.shape[0], dtype) if masses is None else masses
        if monomers is None:
            return weights
        return weights.at[monomers[0] : monomers[1]].set(0)

    def step(state):
        bound = box.bind(state.box_state)
        box_state = box.advance(state.box_state, state.time, h)
        new_bound = box.bind(box_state)
        moved, velocities = free_flight(bound, new_bound, state.positions, state.velocities, h)
        image = box.carry_images(state.image, state.box_state, box_state)
        positions, image = new_bound.wrap(moved, image)
        forces, virial = state.forces, {}
        pair_list, bits = state.pair_list, jnp.int32(0)
        if monomers is not None:
            first, stop = monomers
            moved = stream_monomers(state, first, stop)
            positions = positions.at[first:stop].set(moved.positions)
            image = image.at[first:stop].set(moved.image)
            velocities = velocities.at[first:stop].set(moved.velocities)
            forces = forces.at[first:stop].set(moved.forces)
            virial, pair_list, bits = dict(moved.virial), moved.pair_list, moved.flags
        collision = state.step + 1
        velocities, collision_virial = collide(
            new_bound, positions, velocities, noise.step_key(state.seed, collision)
        )
        if remove_drift:
            velocities = flows.remove_momentum_drift(new_bound, velocities, masses)
        if collision_virial is not None:
            virial["collision"] = collision_virial / h
        if with_virial and bound.velocity_gradient is not None:
            virial["streaming"] = free_flight_stress(
                bound.velocity_gradient, state.velocities, free_weights(state), h
            )
        return state.set(
            positions=positions,
            velocities=velocities,
            forces=forces,
            image=image,
            pair_list=pair_list,
            virial=virial,
            box_state=box_state,
            step=collision,
            time=state.time + h,
            flags=_flag(state, positions, velocities, pair_list, kT, bits, masses),
        )

    return step
