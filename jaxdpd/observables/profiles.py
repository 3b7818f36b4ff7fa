"""Profiles across the box along y: density, flow velocity and temperature per slab.

The "profile" observable records per step, for B equal slabs along y:
    profile/density      particles per unit volume in each slab,
    profile/velocity_x   mean laboratory velocity v_x = c_x + u_x(y) in each slab,
    profile/temperature  Σ m c² / (3 n) of the slab's particles (peculiar velocities),
(NaN-free: an empty slab reports 0).  In a homogeneous flow these are uniform
(thesis §3.5.1: checking that the temperature does not vary spatially confirms that
the flow is homogeneous); in shear the velocity is linear, γ̇ (y − L_y/2).
In a decomposed run each device bins its owned rows and the slabs' sums are added
over the devices before they are divided.
"""

import jax
import jax.numpy as jnp

from jaxdpd.observables.component import Observable, Setting


def slab_centres(length_y: float, bins: int):
    """(B,) centres of the slabs along y."""
    return (jnp.arange(bins) + 0.5) * (length_y / bins)


def profile_sums(bound_box, positions, velocities, masses, bins: int, counted=None):
    """Per-slab particle count, Σ lab v_x and Σ m c² at one step (traced).

    Args:
        counted: (N,) bool, the rows to bin (the owned rows of one device of a
            decomposed run), or None for all.
    Returns:
        (counts, Σ v_x, Σ m c²), each (B,).
    """
    lengths = bound_box.lengths
    slab = jnp.clip(jnp.floor(positions[:, 1] * (bins / lengths[1])).astype(jnp.int32), 0, bins - 1)
    if counted is not None:
        slab = jnp.where(counted, slab, bins)  # out of range: segment_sum drops it
    lab_x = velocities[:, 0]
    if bound_box.velocity_gradient is not None:
        lab_x = lab_x + bound_box.streaming_velocity(positions)[:, 0]
    weight = jnp.ones_like(lab_x) if masses is None else masses
    counts = jax.ops.segment_sum(jnp.ones_like(lab_x), slab, bins)
    twice_kinetic = jax.ops.segment_sum(weight * jnp.sum(velocities**2, axis=1), slab, bins)
    return counts, jax.ops.segment_sum(lab_x, slab, bins), twice_kinetic


def profile_series(bound_box, sums, bins: int) -> dict:
    """Per-slab density, mean lab velocity v_x and temperature from `profile_sums`."""
    counts, momentum_x, twice_kinetic = sums
    lengths = bound_box.lengths
    safe = jnp.maximum(counts, 1)
    volume = lengths[0] * lengths[1] * lengths[2] / bins
    return {
        "profile/density": counts / volume,
        "profile/velocity_x": momentum_x / safe,
        "profile/temperature": twice_kinetic / (3 * safe),
    }


def profile_samples(bound_box, positions, velocities, masses, bins: int) -> dict:
    """Per-slab density, lab velocity v_x and temperature at one step (traced)."""
    sums = profile_sums(bound_box, positions, velocities, masses, bins)
    return profile_series(bound_box, sums, bins)


class Profile(Observable):
    """Per-step density, lab velocity v_x and temperature in output.profile_bins slabs
    along y."""

    name = "profile"
    settings = (Setting("profile_bins", 20, minimum=1, integer=True),)
    decomposes = True
    units = {"density": "r_c^-3", "velocity_x": "r_c/τ"}

    def memory(self, scene, itemsize):
        return {"output.profile_bins": 3 * scene.run.chunk * scene.output.profile_bins * itemsize}

    def sampler(self, context):
        box, masses, bins = context.box, context.masses, context.scene.output.profile_bins

        def sample(previous, state):
            bound_box = box.bind(state.box_state)
            return state, profile_samples(
                bound_box, state.positions, state.velocities, masses, bins
            )

        return sample

    def domain_sampler(self, context):
        box, bins = context.box, context.scene.output.profile_bins

        def sample(ownership, state):
            bound_box = box.bind(state.box_state)
            sums = profile_sums(
                bound_box, state.positions, state.velocities, None, bins, ownership.owned
            )
            return profile_series(bound_box, ownership.across_devices(sums), bins)

        return sample
