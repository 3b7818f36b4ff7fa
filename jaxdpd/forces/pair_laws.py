"""Conservative pair forces.

Soft repulsion of Groot–Warren DPD (thesis eq. 2.4):
    F_ij^C = a_ij (1 − r_ij/r_c) e_ij   for r_ij < r_c, else 0,
with a symmetric species matrix a_ij (thesis §2.2.2, "Chemical species
differentiation").

Weeks–Chandler–Andersen repulsion between Kremer–Grest monomers (see `wca_term`).
"""

import jax.numpy as jnp


def soft_repulsion(weight, a):
    """Scalar law: magnitude a (1 − r/r_c) given the DPD weight w = 1 − r/r_c.

    Args:
        weight: w(r) = 1 − r/r_c within the cut-off, 0 beyond (any shape).
        a: repulsion parameter(s) a_ij, broadcastable to `weight` (energy/length).
    Returns:
        Force magnitude along e_ij (positive = repulsive).
    """
    return a * weight


def soft_repulsion_energy(distance, a, cutoff):
    """Pair potential U = a r_c (1 − r/r_c)² / 2 whose −dU/dr is `soft_repulsion`."""
    weight = jnp.clip(1 - distance / cutoff, 0, None)
    return 0.5 * a * cutoff * weight * weight


def soft_repulsion_term(a_matrix, dtype):
    """Pair term for the composed step: magnitude a_{s_i s_j} w(r_ij).

    Args:
        a_matrix: (S, S) symmetric nested sequence of a_ij.
        dtype: floating dtype of the simulation.
    Returns:
        `term(geometry, context) -> {"conservative": magnitudes}`, with
        `context.species` (N,) int32.
    """
    table = jnp.asarray(a_matrix, dtype)
    if table.shape == (1, 1):
        a = table[0, 0]
        return lambda geometry, context: {"conservative": soft_repulsion(geometry.weight, a)}

    def term(geometry, context):
        a = geometry.gather_pair(table, context.species)
        return {"conservative": soft_repulsion(geometry.weight, a)}

    return term


# Weeks–Chandler–Andersen repulsion (Weeks, Chandler and Andersen, J. Chem. Phys. 54,
# 5237 (1971)): the Lennard-Jones potential cut at its minimum r = 2^{1/6} σ and shifted
# to zero there, between all monomers of Kremer–Grest chains (Ahlrichs & Dünweg,
# J. Chem. Phys. 111, 8225 (1999), eq. 8):
#     U = 4ε [(σ/r)¹² − (σ/r)⁶ + ¼]   for r < 2^{1/6} σ, else 0,
#     F = −dU/dr = (24ε/r) [2 (σ/r)¹² − (σ/r)⁶]   (positive = repulsive).
WCA_RANGE_FACTOR = 2 ** (1 / 6)


def _wca_inverse_sixth(distance_sq, sigma):
    """(inside, (σ/r)⁶) with r² clamped to the range outside it (no overflow at r → ∞
    or division by zero in masked lanes)."""
    range_sq = WCA_RANGE_FACTOR**2 * sigma * sigma
    inside = distance_sq < range_sq
    safe = jnp.where(inside, distance_sq, range_sq)
    return inside, (sigma * sigma / safe) ** 3, safe


def wca_force_over_distance(distance_sq, epsilon, sigma):
    """Scalar law: F(r)/r = 24ε [2 (σ/r)¹² − (σ/r)⁶]/r² within 2^{1/6}σ, else 0.

    Args:
        distance_sq: r² (any shape, r > 0).
        epsilon: ε (energy); sigma: σ (length).
    Returns:
        F/r (force per length), ≥ 0.
    """
    inside, s6, safe = _wca_inverse_sixth(distance_sq, sigma)
    return jnp.where(inside, 24 * epsilon * (2 * s6 * s6 - s6) / safe, 0)


def wca_energy(distance_sq, epsilon, sigma):
    """U(r) = 4ε [(σ/r)¹² − (σ/r)⁶ + ¼] within 2^{1/6}σ, else 0."""
    inside, s6, _ = _wca_inverse_sixth(distance_sq, sigma)
    return jnp.where(inside, 4 * epsilon * (s6 * s6 - s6 + 0.25), 0)


def wca_term(epsilon: float, sigma: float, dtype):
    """Pair term for the composed step: the WCA force magnitude r · F/r.

    The scene's cut-off is the WCA range 2^{1/6}σ, so `geometry.within` is exactly
    the interaction range.

    Args:
        epsilon: ε; sigma: σ.
        dtype: floating dtype of the simulation.
    Returns:
        `term(geometry, context) -> {"conservative": magnitudes}`.
    """
    eps, sig = jnp.asarray(epsilon, dtype), jnp.asarray(sigma, dtype)

    def term(geometry, context):
        distance = geometry.distance
        magnitude = distance * wca_force_over_distance(distance * distance, eps, sig)
        return {"conservative": jnp.where(geometry.within, magnitude, 0)}

    return term
