"""The lattice-Boltzmann fluid's part of the simulation state (SimState.solvent_state)."""

import jax.numpy as jnp

from jaxdpd import pytree


@pytree.dataclass
class FluidState:
    """A lattice-Boltzmann fluid between two LB steps.

    Attributes:
        deviations: (19, n_x, n_y, n_z) populations minus the rest state, f_i − w_i ρ₀
            (mass densities), before the next collision.
        velocity: (3, n_x, n_y, n_z) fluid velocity at the nodes (physical units),
            the one particles see until the next LB step.
        impulse: (3, n_x, n_y, n_z) momentum per volume given to the fluid by the
            particles since the last LB step (applied and reset by the next one).
    """

    deviations: jnp.ndarray
    velocity: jnp.ndarray
    impulse: jnp.ndarray
