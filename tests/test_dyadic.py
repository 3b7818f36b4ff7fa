"""Dyadic sums Σ_i a_i ⊗ b_i (jaxdpd.dyadic): orientation, leading axes, float32
accuracy."""

import jax
import jax.numpy as jnp
import numpy as np

from jaxdpd.dyadic import dyadic_square, dyadic_sum


def test_dyadic_sum_is_the_row_sum_of_outer_products():
    """Small integers, so every sum is exact: S_kl = Σ a_ik b_il with k from `a` (m = 3)
    and l from `b` (n = 2), over two leading axes."""
    rng = np.random.default_rng(0)
    a = rng.integers(-5, 6, size=(4, 7, 3)).astype(np.float32)
    b = rng.integers(-5, 6, size=(4, 7, 2)).astype(np.float32)
    expected = np.einsum("cka,ckb->ab", a, b)
    np.testing.assert_array_equal(np.asarray(dyadic_sum(jnp.asarray(a), jnp.asarray(b))), expected)


def test_float32_dyadic_sum_does_not_accumulate_sequentially():
    """The kinetic tensor of N = 10⁵ unit-variance float32 velocities, compiled as
    inside a step.

    Reference: the float64 sum of the float64 products of the same float32 inputs.
    In the random-walk model of rounding, a sequential float32 accumulation of N terms
    errs by about u√N relative (u = 2⁻²⁴; 316 u here; a jitted `v.T @ v` gave 333 u on
    the CPU, 2·10⁻⁵), and a sum in blocks of √N terms, then over the blocks, by about
    u (N^¼ + N^¼) = 2 u N^¼ (36 u).  The tolerance is the blocked sum's, relative to the
    largest entry: any summation that does not grow its error like one long sequential
    accumulation passes (XLA's reduction: 0.6–2.3 u)."""
    n = 100_000
    velocities = np.random.default_rng(1).standard_normal((n, 3)).astype(np.float32)
    exact = velocities.astype(np.float64).T @ velocities.astype(np.float64)
    tensor = jax.jit(dyadic_sum)(jnp.asarray(velocities), jnp.asarray(velocities))
    tensor = np.asarray(tensor, np.float64)
    u = np.finfo(np.float32).eps / 2
    assert np.max(np.abs(tensor - exact)) <= 2 * u * n**0.25 * np.max(np.abs(exact))


def test_dyadic_square_is_the_symmetric_dyadic_sum():
    """Small integers, so every sum is exact: Σ w_i a_i ⊗ a_i from its 6 distinct
    entries equals the full sum of weighted outer products (NumPy's einsum), with and
    without weights, over two leading axes."""
    rng = np.random.default_rng(2)
    a = rng.integers(-5, 6, size=(4, 7, 3)).astype(np.float32)
    w = rng.integers(1, 4, size=(4, 7)).astype(np.float32)
    for weights in (None, w):
        scale = np.ones((4, 7), np.float32) if weights is None else weights
        expected = np.einsum("ck,cka,ckb->ab", scale, a, a)
        square = dyadic_square(jnp.asarray(a), None if weights is None else jnp.asarray(w))
        np.testing.assert_array_equal(np.asarray(square), expected)


def test_float32_dyadic_square_does_not_accumulate_sequentially():
    """As `test_float32_dyadic_sum_does_not_accumulate_sequentially`, for the kinetic
    tensor's own form: the blocked sum's bound 2 u N^¼ relative to the largest entry."""
    n = 100_000
    velocities = np.random.default_rng(1).standard_normal((n, 3)).astype(np.float32)
    exact = velocities.astype(np.float64).T @ velocities.astype(np.float64)
    tensor = np.asarray(jax.jit(dyadic_square)(jnp.asarray(velocities)), np.float64)
    u = np.finfo(np.float32).eps / 2
    assert np.max(np.abs(tensor - exact)) <= 2 * u * n**0.25 * np.max(np.abs(exact))
