"""Sums of dyadic products over rows: Σ_i a_i ⊗ b_i.

Kinetic tensors, virials and conformation tensors are all such sums over particles,
pairs or springs.  Written as `a.T @ b` inside `jit`, XLA:CPU compiles them to a loop
that accumulates each of the 3 × 3 entries in sequence: slow, and in float32 off by
about u√N relative.  As reductions over the rows they are vectorised and summed in
blocks (about u).  Figures: docs/performance_solvents.md.
"""

import jax.numpy as jnp


def dyadic_sum(a, b):
    """Σ_i a_i ⊗ b_i over every leading axis: (..., m) and (..., n) → (m, n).

    Args:
        a, b: arrays with the same leading shape (rows i), vectors along the last axis.
    Returns:
        (m, n) array S_kl = Σ_i a_ik b_il.
    """
    rows_a = a.reshape(-1, a.shape[-1]).T
    rows_b = b.reshape(-1, b.shape[-1]).T
    return jnp.sum(rows_a[:, None, :] * rows_b[None, :, :], axis=-1)
