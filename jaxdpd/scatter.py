"""Scatters that leave out the entries that add nothing: per-row sums, and the
indices of a mask's True entries."""

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


def nonzero_indices(mask, size: int, fill_value: int):
    """The indices of the True entries of a 1-D `mask`, in increasing order, the first
    `size` of them, padded with `fill_value`: `jnp.nonzero(mask, size=size,
    fill_value=fill_value)[0]`, the same values and dtype.

    `jnp.nonzero` counts with a scatter-add of ones at every entry's running count, so
    all the unselected entries between two selected ones add to one address, which a
    GPU serialises.  Here each selected entry writes its own index at its rank; the
    other entries, and ranks beyond `size`, are dropped.
    """
    indices = jnp.arange(mask.shape[0])
    rank = jnp.cumsum(mask, dtype=indices.dtype) - 1
    target = jnp.where(mask, rank, size)
    return jnp.full(size, fill_value, indices.dtype).at[target].set(indices, mode="drop")
