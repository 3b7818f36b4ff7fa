"""Conservative pair forces.

Soft repulsion of Groot–Warren DPD (thesis eq. 2.4):
    F_ij^C = a_ij (1 − r_ij/r_c) e_ij   for r_ij < r_c, else 0,
with a symmetric species matrix a_ij (thesis §2.2.2, "Chemical species
differentiation").
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
