"""Per-row sums that leave out non-contributing entries (jaxdpd.scatter)."""

import jax
import jax.numpy as jnp
import numpy as np

from jaxdpd.scatter import segment_sum_where


def test_only_contributing_entries_are_summed_whatever_their_rows():
    """Integer values, so every sum is exact. The left-out entries carry non-zero
    values and rows inside the range, so that a sum that kept them, or one that sent
    them to row 0, would differ from the reference (np.add.at over the kept entries)."""
    rng = np.random.default_rng(3)
    n_rows, count = 5, 40
    values = rng.integers(1, 9, size=(count, 3)).astype(np.float32)
    rows = rng.integers(0, n_rows, size=count)
    contributes = rng.random(count) < 0.6
    expected = np.zeros((n_rows, 3), np.float32)
    np.add.at(expected, rows[contributes], values[contributes])
    summed = jax.jit(segment_sum_where, static_argnums=3)(
        jnp.asarray(values), jnp.asarray(rows), jnp.asarray(contributes), n_rows
    )
    np.testing.assert_array_equal(np.asarray(summed), expected)
