"""Sums of dyadic products over rows: Σ_i a_i ⊗ b_i.

Kinetic tensors, virials and conformation tensors are all such sums over particles,
pairs or springs.  Written as `a.T @ b` they are matrix products with a contraction
of length N and a 3 × 3 result, which XLA:CPU runs as one sequential float32
accumulation per entry (relative error ~u√N: 2·10⁻⁵ for 10⁵ unit-variance
velocities) at about 1 GFLOP/s.  As reductions over the rows they are summed in
blocks (relative error ~u) and vectorised: the MPCD step with its temperature
observed ran 1.48× faster (docs/performance_solvents.md).
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
