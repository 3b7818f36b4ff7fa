"""Scatters that leave out the entries that add nothing (jaxdpd.scatter): per-row sums
and the indices of a mask's True entries."""

import jax
import jax.numpy as jnp
import numpy as np

from jaxdpd.scatter import nonzero_indices, segment_sum_where


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


def test_nonzero_indices_are_jnp_nonzero_in_values_and_dtype():
    """Against `jnp.nonzero(mask, size=, fill_value=)` (the NumPy-defined reference):
    sparse, half-full, empty and full masks, with capacities below and above the
    count, under jit."""
    rng = np.random.default_rng(5)
    cases = [(1000, 0.01, 20), (1000, 0.5, 20), (1000, 0.0, 5), (1000, 1.0, 1200), (7, 0.5, 3)]
    for n, fraction, size in cases:
        mask = jnp.asarray(rng.random(n) < fraction)
        expected = jnp.nonzero(mask, size=size, fill_value=n)[0]
        found = jax.jit(nonzero_indices, static_argnums=(1, 2))(mask, size, n)
        assert found.dtype == expected.dtype
        np.testing.assert_array_equal(np.asarray(found), np.asarray(expected))
