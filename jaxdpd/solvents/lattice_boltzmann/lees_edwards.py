"""Lees–Edwards boundary of the lattice: the populations that stream across the sheared
y boundary (Wagner & Pagonabarraga, J. Stat. Phys. 107, 521 (2002); ESPResSo's
waLBerla bridge, `InterpolateAndShiftAtBoundary` and `lees_edwards.py` of its kernel
generator).

Geometry (jaxdpd.geometry.boxes.lees_edwards): the image above the box is displaced by
Δ along x and moves with v = γ̇ L_y along x.  In a sheared box the nodes sit at the
centres of the lattice cells along y, y_j = (j + ½) a, so the boundary plane y = 0 ≡
L_y lies midway between the layers j = n_y − 1 and j = 0 (as in ESPResSo) and the
laminar profile u_x = γ̇ (y − L_y/2) has zero mean over the nodes.

A population with c_y = +1 leaving the top layer arrives in the bottom layer of the
image above, i.e. in the bottom layer of the box at x − Δ, and enters a fluid that
moves with −v relative to the one it left; with c_y = −1 the signs flip.  Two
operations make it fit its new neighbourhood:

1. Galilean shift (in the collision, at the boundary layers, on the outgoing
   populations only): f_i ← f_i + f_i^eq(ρ, u ∓ v x̂) − f_i^eq(ρ, u), with ρ and u
   the post-collision density and velocity of the node.  It changes the moments of
   the node's equilibrium exactly as a Galilean transformation does (j → j ∓ ρv,
   Π → Π ∓ (j v + v j) + ρ v v) and leaves the non-equilibrium part alone.
2. Translation along x by ±Δ/a nodes of the layer of arriving populations.  ESPResSo
   interpolates linearly between the two nearest nodes; that averages two
   independent thermal fluctuations and removes up to half of their variance at every
   step (the boundary layers would be colder than the bulk).  Here the layer is
   translated in Fourier space, each wave e^{i k x} by its phase e^{i k Δ}: exact for
   every wave the layer can hold, orthogonal (it keeps the sum over the layer, so
   mass and momentum, and the sum of squares, so the fluctuations), and equal to the
   linear interpolation for a layer that is uniform along x (laminar shear).  The
   Nyquist wave of an even n_x cannot take a fractional phase in a real field; it is
   moved by the nearest whole number of nodes, which keeps the map orthogonal.
"""

import jax
import jax.numpy as jnp
import numpy as np

from jaxdpd.solvents.lattice_boltzmann import counter_noise
from jaxdpd.solvents.lattice_boltzmann.coupling import Stencil, trilinear_stencil
from jaxdpd.solvents.lattice_boltzmann.fluid import (
    equilibrium_deviations,
    lattice_update,
    stream,
)
from jaxdpd.solvents.lattice_boltzmann.lattice import VELOCITIES

UP = np.flatnonzero(VELOCITIES[:, 1] == 1)
"""Populations with c_y = +1 (they cross the top boundary)."""
DOWN = np.flatnonzero(VELOCITIES[:, 1] == -1)
"""Populations with c_y = −1 (they cross the bottom boundary)."""


def translate_layer(layer, shift):
    """layer(x + shift) along axis −2 of a periodic layer, wave by wave (module docstring).

    Args:
        layer: (..., n_x, n_z) real values at the nodes.
        shift: translation in nodes (traced scalar, any real value).
    Returns:
        Array of the shape and dtype of `layer`.
    """
    n = layer.shape[-2]
    waves = np.arange(n // 2 + 1)
    phase_shift = shift * jnp.asarray(waves, layer.dtype)
    if n % 2 == 0:
        phase_shift = phase_shift.at[-1].set(jnp.round(shift) * (n // 2))
    phase = jnp.asarray(2 * np.pi / n, layer.dtype) * phase_shift
    spectrum = jnp.fft.rfft(layer, axis=-2) * jnp.exp(1j * phase)[:, None]
    return jnp.fft.irfft(spectrum, n=n, axis=-2).astype(layer.dtype)


def galilean_shift(density, momentum, jump):
    """f^eq(ρ, u + jump x̂) − f^eq(ρ, u) of one layer of nodes (module docstring, 1).

    Args:
        density: (n_x, n_z) ρ.
        momentum: (3, n_x, n_z) post-collision lattice momentum density j.
        jump: velocity change along x (lattice units a/τ).
    Returns:
        (19, n_x, n_z) population changes.
    """
    velocity = momentum / density
    shifted = velocity.at[0].add(jump)
    return equilibrium_deviations(density, shifted, density) - equilibrium_deviations(
        density, velocity, density
    )


def _arrivals(layer, populations, jump, density, momentum, shift):
    """The layer of `populations` (c_y = ±1) that a boundary layer sends across: the
    Galilean shift by `jump`, the in-plane streaming by (c_x, c_z), and the
    translation by `shift` nodes, (len(populations), n_x, n_z)."""
    sent = layer[populations] + galilean_shift(density, momentum, jump)[populations]
    moved = [
        jnp.roll(sent[k], (int(VELOCITIES[i, 0]), int(VELOCITIES[i, 2])), axis=(0, 1))
        for k, i in enumerate(populations)
    ]
    return translate_layer(jnp.stack(moved), shift)


def sheared_stream(post_collision, density, momentum, offset_nodes, jump):
    """Stream post-collision populations across a Lees–Edwards boundary in y.

    Args:
        post_collision: (19, n_x, n_y, n_z) populations (or their deviations).
        density: (n_x, n_y, n_z) ρ of the nodes.
        momentum: (3, n_x, n_y, n_z) post-collision lattice momentum density.
        offset_nodes: Δ/a, the image offset in nodes.
        jump: v τ/a = γ̇ L_y τ/a, the velocity of the image above (lattice units).
    Returns:
        (19, n_x, n_y, n_z) streamed populations.
    """
    up = _arrivals(
        post_collision[:, :, -1], UP, -jump, density[:, -1], momentum[:, :, -1], offset_nodes
    )
    down = _arrivals(
        post_collision[:, :, 0], DOWN, jump, density[:, 0], momentum[:, :, 0], -offset_nodes
    )
    return stream(post_collision).at[UP, :, 0].set(up).at[DOWN, :, -1].set(down)


def boundary(box, box_state, grid_spacing: float, time_step: float, dtype):
    """(Δ/a, γ̇ L_y τ/a) of an LB step that ends at the box state `box_state`; the rate
    is taken at the middle of the LB step (an oscillatory shear changes it)."""
    rate = box.shear_rate_at(box_state, box_state.time - 0.5 * time_step)
    offset = box_state.offset / jnp.asarray(grid_spacing, dtype)
    return offset, rate * jnp.asarray(box.lengths[1] * time_step / grid_spacing, dtype)


def image_stencil(positions, bound_box, grid_spacing: float, nodes) -> Stencil:
    """The 8 nodes around each bead of a sheared box and their weights: the bead
    coupling across the Lees–Edwards boundary (Ahlrichs & Dünweg's trilinear stencil,
    jaxdpd.solvents.lattice_boltzmann.coupling, on the sheared lattice).

    Nodes sit at y_j = (j + ½) a.  A bead below the first layer (y < a/2) is taken at
    its image above, (x + Δ, y + L_y); a bead whose upper layer lies beyond the last
    one reads and feeds that layer in the image above, i.e. the bottom layer of the
    box at x − Δ, with its own x weights (ESPResSo couples the bead's Lees–Edwards
    images to the nodes they touch in the same way).  The weights still sum to 1 and
    the same stencil interpolates and spreads, so the exchange conserves momentum.

    Args:
        positions: (N, 3) wrapped positions.
        bound_box: the Lees–Edwards box at this instant (its offset Δ).
        grid_spacing: a; nodes: (n_x, n_y, n_z).
    """
    a = jnp.asarray(grid_spacing, positions.dtype)
    offset = bound_box.offset.astype(positions.dtype)
    below = positions[:, 1] < 0.5 * a
    lifted = jnp.where(below, bound_box.lengths[1], 0.0) - 0.5 * a
    located = positions.at[:, 1].add(lifted).at[:, 0].add(jnp.where(below, offset, 0.0))
    top = located[:, 1] >= (nodes[1] - 1) * a
    return trilinear_stencil(located, grid_spacing, nodes, jnp.where(top, -offset, 0.0))


def streaming_at_nodes(stencil: Stencil, bound_box, grid_spacing: float, nodes):
    """Σ_r δ_r u_s(y_r) (N, 3): the laminar velocity γ̇ (y_r − L_y/2) x̂ of the stencil's
    nodes (primary layers, y_r = (j + ½) a), interpolated to each bead.  The fluid's
    velocity minus it is its peculiar velocity, the same at a node and at its images,
    so a bead with peculiar velocity c sees w = c − Σ_r δ_r [u(r) − u_s(y_r)]."""
    dtype = stencil.weights.dtype
    layer = (stencil.nodes // nodes[2]) % nodes[1]
    heights = (layer.astype(dtype) + 0.5) * grid_spacing - 0.5 * bound_box.lengths[1]
    along_x = bound_box.current_shear_rate * jnp.sum(stencil.weights * heights, axis=1)
    return jnp.zeros((stencil.weights.shape[0], 3), dtype).at[:, 0].set(along_x)


def laminar_deviations(fluid, shear_rate: float, dtype):
    """Equilibrium deviations of the laminar profile u_x = γ̇ (y_j − L_y/2) at the node
    layers y_j = (j + ½) a, (19, n_x, n_y, n_z): the start of a sheared fluid (its
    viscous stress builds up within a few relaxation times).

    Args:
        fluid: the FluidParameters.
        shear_rate: γ̇ at time 0 (1/time).
        dtype: floating dtype.
    """
    n_x, n_y, n_z = fluid.nodes
    heights = (np.arange(n_y) + 0.5 - 0.5 * n_y) * fluid.grid_spacing
    velocity = np.zeros((3, n_x, n_y, n_z))
    velocity[0] = (shear_rate * heights / fluid.lattice_speed)[None, :, None]
    density = jnp.full(fluid.nodes, fluid.density, dtype)
    return equilibrium_deviations(density, jnp.asarray(velocity, dtype), fluid.density)


def fluid_run(fluid, box, dtype, steps: int, observe, seed: int = 0):
    """A bare sheared fluid (no beads) stepped `steps` LB steps, the box advanced by τ
    per step as the coupled integrator does: for studies and tests of the boundary.

    Args:
        fluid: the FluidParameters; box: a LeesEdwardsBox; dtype: floating dtype.
        steps: LB steps (static).
        observe: `observe(deviations, density, velocity, *extra) -> pytree`, sampled
            after every step.
        seed: seed of the lattice noise.
    Returns:
        Jitted `run(deviations, *extra) -> (final deviations, per-step samples)`,
        starting from the box's initial state.
    """
    update = lattice_update(fluid, dtype, "uniform", sheared_stream)
    impulse = jnp.zeros((3, *fluid.nodes), dtype)

    @jax.jit
    def run(deviations, *extra):
        def body(carry, lb_step):
            f, state = carry
            state = box.advance(state, None, fluid.time_step)
            key = counter_noise.family_key(seed, lb_step, counter_noise.LATTICE_SALT)
            edge = boundary(box, state, fluid.grid_spacing, fluid.time_step, dtype)
            f, density, velocity = update(f, impulse, key, edge)
            return (f, state), observe(f, density, velocity, *extra)

        start = (deviations, box.initial_state(dtype))
        (final, _), samples = jax.lax.scan(body, start, jnp.arange(1, steps + 1))
        return final, samples

    return run
