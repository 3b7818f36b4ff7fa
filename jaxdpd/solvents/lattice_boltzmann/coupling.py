"""Point-particle friction coupling of beads to a lattice-Boltzmann fluid.

Ahlrichs & Dünweg, J. Chem. Phys. 111, 8225 (1999), §II.C: a bead at R with
velocity V feels

    F = −ζ [V − u(R)] + f,     ⟨f_α(t) f_β(t')⟩ = 2 k_BT ζ δ_αβ δ(t − t')   (eqs. 9, 15, 16)

with u(R) = Σ_r δ_r u(r) the trilinear interpolation from the 8 nodes of the lattice
cell holding R (eqs. 10, 11), and the fluid at those nodes receives −F δ_r with the
same weights, so the total momentum of beads and fluid is conserved exactly and no
mass is moved (eqs. 12, 13).  Nodes sit at r = (i, j, k) a.

Over one MD step Δt the friction and its noise act on the relative velocity
w = V − u(R) of the bead (mass M) and the fluid it touches.  Momentum −P given to the
nodes as −P δ_r changes u(R) by −P Σ_r δ_r²/(ρ₀ a³), so w relaxes with the reduced
mass m_red = [1/M + Σ_r δ_r²/(ρ₀ a³)]⁻¹, and the exact Ornstein–Uhlenbeck step

    w' = w e^{−y} + √(k_BT/m_red (1 − e^{−2y})) ξ,    y = ζ Δt/m_red,
    P  = m_red (w' − w)    to the bead,    −P δ_r/a³ to the nodes (momentum density),

leaves the Maxwell–Boltzmann distribution of the bead and the nodes' momenta
invariant for any Δt: the pair-wise exact thermostat of Lowe (Europhys. Lett. 47,
145 (1999)) and Peters (Europhys. Lett. 66, 311 (2004)), applied to the bead and its
interpolated fluid velocity.  To first order in y, P = −ζ w Δt + √(2 k_BT ζ Δt) ξ:
the friction and random force of eqs. 9 and 16.  The fluid velocity u(R) the bead
sees includes the momentum given to the nodes since the last LB step (u = u_LB +
impulse/ρ₀), so the fluid responds at once; the LB step then carries that momentum
on (jaxdpd.solvents.lattice_boltzmann.fluid).
"""

import jax.numpy as jnp
import numpy as np

from jaxdpd import pytree

# A NumPy constant: a JAX array made at import would compile (reading a scene imports
# this module, and must compile nothing).
_CORNERS = np.asarray([[dx, dy, dz] for dx in (0, 1) for dy in (0, 1) for dz in (0, 1)], np.int32)


@pytree.dataclass
class Stencil:
    """The 8 nodes around each bead and their trilinear weights.

    Attributes:
        nodes: (N, 8) int32 flat node indices (i n_y + j) n_z + k.
        weights: (N, 8) δ_r, summing to 1 per bead (eq. 10).
    """

    nodes: jnp.ndarray
    weights: jnp.ndarray


def trilinear_stencil(
    positions, grid_spacing: float, nodes: tuple[int, int, int], upper_shift=None
) -> Stencil:
    """Cell corners and weights of eq. 10 for each position.

    Args:
        positions: (N, 3) positions (any periodic image: indices are folded).
        grid_spacing: a.
        nodes: (n_x, n_y, n_z) lattice shape.
        upper_shift: None, or (N,) x displacement of the upper layer of corners (those
            one node up in y): the 4 upper corners and their x weights are taken at
            x + upper_shift (a Lees–Edwards image layer,
            jaxdpd.solvents.lattice_boltzmann.lees_edwards.image_stencil).
    Returns:
        Stencil.
    """
    scaled = positions / jnp.asarray(grid_spacing, positions.dtype)
    lower = jnp.floor(scaled)
    fraction = scaled - lower  # (N, 3) in [0, 1)
    lower, fraction = lower.astype(jnp.int32)[:, None, :], fraction[:, None, :]
    if upper_shift is not None:
        shifted = scaled[:, 0] + upper_shift / jnp.asarray(grid_spacing, positions.dtype)
        shifted_lower = jnp.floor(shifted)
        upper = _CORNERS[None, :, 1] == 1  # (1, 8)
        lower = jnp.broadcast_to(lower, (positions.shape[0], 8, 3))
        fraction = jnp.broadcast_to(fraction, lower.shape)
        lower = lower.at[..., 0].set(
            jnp.where(upper, shifted_lower.astype(jnp.int32)[:, None], lower[..., 0])
        )
        fraction = fraction.at[..., 0].set(
            jnp.where(upper, (shifted - shifted_lower)[:, None], fraction[..., 0])
        )
    shape = jnp.asarray(nodes, jnp.int32)
    corners = (lower + _CORNERS[None]) % shape  # (N, 8, 3)
    flat = (corners[..., 0] * nodes[1] + corners[..., 1]) * nodes[2] + corners[..., 2]
    per_axis = jnp.where(_CORNERS[None] == 1, fraction, 1 - fraction)
    return Stencil(flat, jnp.prod(per_axis, axis=-1))


def interpolate(field, stencil: Stencil):
    """u(R) = Σ_r δ_r u(r) (eq. 11).

    Args:
        field: (3, n_x, n_y, n_z) node vectors.
        stencil: from `trilinear_stencil`.
    Returns:
        (N, 3).
    """
    flat = field.reshape(3, -1)
    return jnp.einsum("anc,nc->na", flat[:, stencil.nodes], stencil.weights)


def spread(field, stencil: Stencil, values):
    """field(r) += Σ_beads δ_r value: the same weights as `interpolate`, so Σ_r of
    what is added equals Σ of the values exactly (up to round-off).

    Args:
        field: (3, n_x, n_y, n_z).
        stencil: from `trilinear_stencil`.
        values: (N, 3) per-bead vectors.
    Returns:
        The updated field.
    """
    shares = values[:, None, :] * stencil.weights[..., None]  # (N, 8, 3)
    flat = field.reshape(3, -1)
    # A scatter-add into the (loop-carried) field: XLA updates it in place, so an MD
    # step touches 8 nodes per bead, not the whole lattice.
    flat = flat.at[:, stencil.nodes.reshape(-1)].add(shares.reshape(-1, 3).T)
    return flat.reshape(field.shape)


def reduced_mass(stencil: Stencil, masses, node_mass: float):
    """m_red = [1/M + Σ_r δ_r²/(ρ₀ a³)]⁻¹ of each bead and the fluid it touches.

    Args:
        stencil: the beads' stencil.
        masses: bead masses M, scalar or (N, 1).
        node_mass: ρ₀ a³, the mass of fluid per node.
    Returns:
        (N, 1).
    """
    weights_sq = jnp.sum(stencil.weights * stencil.weights, axis=1, keepdims=True)
    return 1 / (1 / masses + weights_sq / node_mass)


def friction_impulse(relative_velocity, reduced_masses, friction: float, dt: float, kT, xi):
    """Impulse P = m_red (w' − w) on each bead (module docstring); the fluid gets −P.

    Args:
        relative_velocity: (N, 3) w = V − u(R).
        reduced_masses: (N, 1) from `reduced_mass`.
        friction: ζ; dt: Δt.
        kT: k_BT, or None for no noise (nothing random traced).
        xi: (N, 3) unit-variance variates (ignored without noise).
    Returns:
        (N, 3) impulses.
    """
    y = friction * dt / reduced_masses
    impulse = reduced_masses * jnp.expm1(-y) * relative_velocity
    if kT is None:
        return impulse
    return impulse + jnp.sqrt(-kT * reduced_masses * jnp.expm1(-2 * y)) * xi
