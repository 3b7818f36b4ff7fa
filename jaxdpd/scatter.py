"""Per-row sums that leave out the entries that add nothing."""

import jax
import jax.numpy as jnp


def segment_sum_where(values, rows, contributes, n_rows: int):
    """Σ of `values` into `n_rows` rows by `rows`, leaving out the entries where
    `contributes` is False. Callers hold zeros there (a pair list's padding, pairs
    beyond the cutoff), so the sums equal `segment_sum`'s.

    Those entries are sent to row `n_rows`, which `segment_sum` drops. Left at a valid
    row such as 0, they all add to that one address, and a GPU serialises those atomic
    additions (docs/performance_gpu.md).

    Args:
        values: (M, ...) entries.
        rows: (M,) int row of each entry, in [0, n_rows) where it contributes.
        contributes: (M,) bool.
        n_rows: rows of the result.
    Returns:
        (n_rows, ...) sums.
    """
    return jax.ops.segment_sum(values, jnp.where(contributes, rows, n_rows), n_rows)
