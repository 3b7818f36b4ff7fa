"""Beads in a lattice-Boltzmann fluid: MD sub-steps between LB steps.

The LB time step τ is n MD time steps Δt (Ahlrichs & Dünweg, J. Chem. Phys. 111,
8225 (1999), §II.B: "there is a priori no need to set Δt = τ").  One MD step is the
symmetric splitting B A O A B (Leimkuhler and Matthews, Appl. Math. Res. Express
2013, 34) of velocity Verlet around the friction coupling:

    B   V ← V + ½Δt F_c/M              conservative forces (pairs, bonds)
    A   R ← R + ½Δt V
    O   the bead and the fluid nodes around R exchange the friction impulse P
        (exact Ornstein–Uhlenbeck step of their relative velocity,
        jaxdpd.solvents.lattice_boltzmann.coupling): V ← V + P/M, impulse field −P δ_r/a³
    A   R ← R + ½Δt V
    B   V ← V + ½Δt F_c(R)/M

and after every n-th MD step the fluid makes one LB step that applies the impulse
field (jaxdpd.solvents.lattice_boltzmann.fluid).  Between LB steps the fluid velocity a bead
sees is that of the last LB step plus the impulse given since, over ρ₀.  Bead
momentum, plus fluid momentum, plus the momentum waiting in the impulse field is
conserved to round-off at every step; for beads without conservative forces the
step leaves the joint Maxwell–Boltzmann distribution of beads and fluid invariant
at linear order (no Δt or τ error in ⟨V²⟩).

In a Lees–Edwards box (steady or oscillatory shear) the beads carry peculiar
velocities c = V − γ̇ (y − L_y/2) x̂: each A is a free flight of the laboratory velocity
(R ← R + ½Δt (c + u_s(R)), c_x ← c_x − ½Δt γ̇ c_y, exact for shear), O reads the
fluid's peculiar velocity through the beads' Lees–Edwards images, and the LB step
streams across the sheared boundary (jaxdpd.solvents.lattice_boltzmann.lees_edwards).

The LB step is a `lax.cond` on the step counter (none for n = 1).  Under `jax.vmap`
a batched counter turns it into a select that computes the LB step at every MD step;
replicas that share the counter (vmap with in_axes None for `step` and `time`) keep
the branch.
"""

import jax
import jax.numpy as jnp
import numpy as np

from jaxdpd.engine import errors
from jaxdpd.engine.integrators import _flag
from jaxdpd.geometry import flows
from jaxdpd.solvents.lattice_boltzmann import counter_noise, lees_edwards
from jaxdpd.solvents.lattice_boltzmann.coupling import (
    friction_impulse,
    interpolate,
    reduced_mass,
    spread,
    trilinear_stencil,
)
from jaxdpd.solvents.lattice_boltzmann.fluid import (
    FluidParameters,
    lattice_update,
    mass_and_momentum,
    thermal_deviations,
)
from jaxdpd.solvents.lattice_boltzmann.state import FluidState


def initial_fluid_state(
    fluid: FluidParameters, seed: int, dtype, shear_rate: float | None = None
) -> FluidState:
    """A fluid in thermal equilibrium (host-side draw; seeded by `seed`, in a NumPy
    stream separate from the particle placement's), at rest or, with a `shear_rate`,
    in the laminar profile of a sheared box (lees_edwards.laminar_deviations)."""
    rng = np.random.default_rng([seed, 0x4C42])
    deviations = jnp.asarray(thermal_deviations(fluid, rng, dtype))
    if shear_rate is not None:
        deviations = deviations + lees_edwards.laminar_deviations(fluid, shear_rate, dtype)
    mass, momentum = mass_and_momentum(deviations)
    velocity = jnp.asarray(fluid.lattice_speed, dtype) * momentum / (fluid.density + mass)
    return FluidState(deviations, velocity, jnp.zeros_like(velocity))


def fluid_momentum(fluid: FluidParameters, state: FluidState):
    """Total momentum of the fluid, counting the impulse not yet applied (3,):
    a³ Σ_r (j(r) a/τ + impulse(r))."""
    _, momentum = mass_and_momentum(state.deviations)
    volume = fluid.grid_spacing**3
    per_node = fluid.lattice_speed * momentum + state.impulse
    return volume * jnp.sum(per_node.reshape(3, -1), axis=1)


def coupled_step(
    box,
    dt: float,
    substeps: int,
    interactions,
    fluid: FluidParameters,
    friction: float,
    dtype,
    masses=None,
    noise_law: str = "uniform",
    external_force=None,
    fluid_force_density=None,
):
    """The MD step of beads coupled to an LB fluid (module docstring).

    Args:
        box: the periodic box (edges n_α a).
        dt: MD time step Δt.
        substeps: n = τ/Δt, MD steps per LB step (static).
        interactions: `interactions(positions, velocities, state) -> (forces, virial,
            state, bits)`, the conservative bead forces and the state with its
            neighbour lists refreshed (see jaxdpd.engine.integrators).
        fluid: the fluid's parameters (its k_BT is the beads' too).
        friction: bare friction ζ (mass/time).
        dtype: floating dtype.
        masses: (N,) bead masses, or None for unit masses.
        noise_law: "uniform" or "gaussian" unit-variance variates (k_BT > 0).
        external_force: optional `external_force(state) -> (N, 3)` added to the
            conservative forces (e.g. a constant drag force in tests); None traces
            nothing.
        fluid_force_density: optional (3,) uniform force per volume on the fluid
            (e.g. the counter force of a dragged bead), applied at every LB step;
            None traces nothing.
    Returns:
        `step(state) -> state` advancing Δt; state.solvent_state is a FluidState.
    """
    dt_ = jnp.asarray(dt, dtype)
    half = 0.5 * dt_
    bead_mass = jnp.asarray(1.0 if masses is None else masses[:, None], dtype)
    kT = fluid.kT
    noise_kT = jnp.asarray(kT, dtype) if kT > 0 else None
    if kT > 0:
        draw = counter_noise.NOISE_LAWS[noise_law]
    node_mass = fluid.density * fluid.grid_spacing**3
    inverse_density = jnp.asarray(1 / fluid.density, dtype)
    inverse_volume = jnp.asarray(1.0 / fluid.grid_spacing**3, dtype)
    sheared = box.flow_kind == "shear"
    update_fluid = lattice_update(
        fluid, dtype, noise_law, lees_edwards.sheared_stream if sheared else None
    )
    # No runaway check without a temperature (a deterministic fluid).
    runaway_scale = kT if kT > 0 else np.inf

    def forces_at(positions, velocities, state):
        forces, virial, refreshed, bits = interactions(positions, velocities, state)
        if external_force is not None:
            forces = forces + external_force(state)
        return forces, virial, refreshed, bits

    body_impulse = None
    if fluid_force_density is not None:
        force = np.asarray(fluid_force_density, np.float64) * fluid.time_step
        body_impulse = jnp.asarray(force, dtype).reshape(3, 1, 1, 1)

    def lattice_step(solvent, seed, lb_step, box_state):
        key = counter_noise.family_key(seed, lb_step, counter_noise.LATTICE_SALT)
        impulse = solvent.impulse if body_impulse is None else solvent.impulse + body_impulse
        boundary = ()
        if sheared:
            boundary = lees_edwards.boundary(
                box, box_state, fluid.grid_spacing, fluid.time_step, dtype
            )
        deviations, density, velocity = update_fluid(solvent.deviations, impulse, key, boundary)
        healthy = jnp.all(density > 0) & jnp.all(jnp.isfinite(velocity))
        bits = jnp.where(healthy, 0, errors.StepError.FLUID_INVALID).astype(jnp.int32)
        return FluidState(deviations, velocity, jnp.zeros_like(solvent.impulse)), bits

    def fluid_velocity_at(solvent, stencil):
        """u(R) the beads see: the last LB velocity plus the impulse given since, /ρ₀."""
        return interpolate(solvent.velocity, stencil) + inverse_density * interpolate(
            solvent.impulse, stencil
        )

    def drift(bound, positions, velocities):
        """Half a step of free flight in a sheared box: the laboratory velocity
        c + u_s(R) stays, so the peculiar velocity c loses ½Δt γ̇ c_y along x (SLLOD,
        exact for shear; jaxdpd.geometry.flows)."""
        moved = positions + half * flows.drift_velocity(bound, positions, velocities)
        return moved, velocities + half * flows.sllod_drag(bound, velocities)

    def sheared_friction_step(state, velocities):
        """A and O of a sheared box: positions, peculiar velocities, stencil, the
        fluid's peculiar velocity at the beads (jaxdpd.solvents.lattice_boltzmann
        .lees_edwards), the box state at the end of the step."""
        middle = box.bind(box.advance(state.box_state, state.time, half))
        midpoint, velocities = drift(middle, state.positions, velocities)
        located, _ = middle.wrap(midpoint, state.image)
        stencil = lees_edwards.image_stencil(located, middle, fluid.grid_spacing, fluid.nodes)
        laminar = lees_edwards.streaming_at_nodes(stencil, middle, fluid.grid_spacing, fluid.nodes)
        fluid_velocities = fluid_velocity_at(state.solvent_state, stencil) - laminar
        return middle, midpoint, velocities, stencil, fluid_velocities

    def step(state):
        solvent = state.solvent_state
        new_step = state.step + 1
        velocities = state.velocities + half * state.forces / bead_mass
        if sheared:
            middle, midpoint, velocities, stencil, fluid_velocities = sheared_friction_step(
                state, velocities
            )
        else:
            midpoint = state.positions + half * velocities
            stencil = trilinear_stencil(midpoint, fluid.grid_spacing, fluid.nodes)
            fluid_velocities = fluid_velocity_at(solvent, stencil)
        xi = None
        if noise_kT is not None:
            key = counter_noise.family_key(state.seed, new_step, counter_noise.BEAD_SALT)
            xi = draw(key, velocities.shape[0], 3, dtype).T
        impulse = friction_impulse(
            velocities - fluid_velocities,
            reduced_mass(stencil, bead_mass, node_mass),
            friction,
            dt,
            noise_kT,
            xi,
        )
        coupled = velocities + impulse / bead_mass
        impulse_field = spread(solvent.impulse, stencil, -inverse_volume * impulse)
        if sheared:
            box_state = box.advance(state.box_state, state.time, dt_)
            moved, coupled = drift(middle, midpoint, coupled)
            image = box.carry_images(state.image, state.box_state, box_state)
            positions, image = box.bind(box_state).wrap(moved, image)
            advanced = state.set(
                positions=positions, image=image, box_state=box_state, step=new_step
            )
        else:
            positions, image = box.wrap(midpoint + half * coupled, state.image)
            advanced = state.set(positions=positions, image=image, step=new_step)
        forces, virial, advanced, bits = forces_at(positions, coupled, advanced)
        velocities = coupled + half * forces / bead_mass
        solvent = FluidState(solvent.deviations, solvent.velocity, impulse_field)
        if substeps == 1:
            solvent, fluid_bits = lattice_step(solvent, state.seed, new_step, advanced.box_state)
        else:
            solvent, fluid_bits = jax.lax.cond(
                new_step % substeps == 0,
                lambda s: lattice_step(s, state.seed, new_step // substeps, advanced.box_state),
                lambda s: (s, jnp.asarray(0, jnp.int32)),
                solvent,
            )
        return advanced.set(
            velocities=velocities,
            forces=forces,
            virial=virial,
            time=state.time + dt_,
            solvent_state=solvent,
            flags=_flag(
                state,
                positions,
                velocities,
                advanced.pair_list,
                runaway_scale,
                bits | fluid_bits,
                masses,
            ),
        )

    return step
