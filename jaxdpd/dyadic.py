"""Sums of dyadic products over rows: Σ_i a_i ⊗ b_i.

Kinetic tensors, virials and conformation tensors are all such sums over particles,
pairs or springs.  Written as `a.T @ b` inside `jit`, XLA:CPU compiles them to a loop
that accumulates each of the 3 × 3 entries in sequence: slow, and in float32 off by
about u√N relative.  As reductions over the rows they are vectorised and summed in
blocks (about u).  Figures: docs/performance_solvents.md.
"""

import jax.numpy as jnp
import numpy as np


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


def dyadic_square(a, weights=None):
    """Σ_i w_i a_i ⊗ a_i over every leading axis: (..., m) → (m, m), symmetric.

    Only the m(m + 1)/2 distinct entries are summed (6 of 9 in three dimensions),
    each as its own reduction over all rows, and mirrored: XLA fuses each product
    into its sum, on a CPU and on a GPU (docs/performance_solvents.md).

    Args:
        a: array, vectors along the last axis.
        weights: w_i with a's leading shape, or None for 1.
    Returns:
        (m, m) array S_kl = Σ w_i a_ik a_il.
    """
    m = a.shape[-1]
    rows = a.reshape(-1, m).T
    weighted = rows if weights is None else rows * weights.reshape(-1)
    pairs = [(k, l) for k in range(m) for l in range(k, m)]
    sums = jnp.stack([jnp.sum(weighted[k] * rows[l]) for k, l in pairs])
    entry = {pair: n for n, pair in enumerate(pairs)}
    mirror = np.array([[entry[min(k, l), max(k, l)] for l in range(m)] for k in range(m)])
    return sums[mirror]
