"""Block averages (jaxdpd.analysis.statistics) against exact results for an AR(1) process."""

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from jaxdpd.analysis.statistics import block_average, blocking_analysis


def _ar1(key, n_series, length, phi, dtype=jnp.float64):
    """Stationary AR(1): x_t = phi x_{t-1} + sqrt(1 - phi^2) e_t, unit variance."""
    noise = jax.random.normal(key, (length, n_series), dtype=dtype)
    x0 = noise[0]

    def step(x, e):
        x = phi * x + np.sqrt(1 - phi**2) * e
        return x, x

    _, xs = jax.lax.scan(step, x0, noise[1:])
    return jnp.concatenate([x0[None], xs])


def _var_of_mean(m, phi):
    """Exact variance of the mean of m consecutive AR(1) samples (unit variance):
    (1/m^2) sum_{i,j} phi^|i-j| = (1/m) [1 + 2 sum_k (1 - k/m) phi^k]."""
    k = np.arange(1, m)
    return (1 + 2 * np.sum((1 - k / m) * phi**k)) / m


def test_block_sem_matches_exact_expectation_for_ar1():
    """E[sem^2] of the block estimator is exactly (V_block - V_total)/(n_b - 1) for any
    stationary series (expand the sum of squares); for AR(1) both variances are known in
    closed form.  Averaged over 400 independent series, the mean of sem^2 must agree
    within 4 standard errors of that mean; and with blocks >> correlation time
    (phi = 0.9: tau ~ 19 samples, blocks of 625) it is within 5 % of the true variance
    of the mean (the block estimator's known downward bias)."""
    phi, length, n_blocks, n_series = 0.9, 10000, 16, 400
    x = _ar1(jax.random.key(0), n_series, length, phi)
    _, sem = block_average(x, n_blocks)
    s2 = np.asarray(sem) ** 2
    m = length // n_blocks
    v_block, v_total = _var_of_mean(m, phi), _var_of_mean(length, phi)
    expected = (v_block - v_total) / (n_blocks - 1)
    se_of_mean = s2.std(ddof=1) / np.sqrt(n_series)
    assert abs(s2.mean() - expected) < 4 * se_of_mean
    assert abs(expected / v_total - 1) < 0.05


def test_block_average_mean_dtype_and_axis():
    x = jnp.arange(103, dtype=jnp.float32).reshape(103, 1) * jnp.ones((1, 2), jnp.float32)
    mean, sem = block_average(x, 10, axis=0)
    assert mean.dtype == jnp.float32 and sem.dtype == jnp.float32
    # the first 3 samples are dropped so that 10 blocks of 10 remain
    np.testing.assert_allclose(mean, np.full(2, np.arange(3, 103).mean()), rtol=1e-6)
    mean_t, _ = block_average(x.T, 10, axis=1)
    np.testing.assert_allclose(mean_t, mean)


def test_blocking_analysis_plateau_for_white_noise():
    """For uncorrelated samples every blocking level estimates sigma/sqrt(T); the levels
    with >= 64 blocks agree with it within 4 of their own relative errors
    1/sqrt(2 (n - 1))."""
    x = jax.random.normal(jax.random.key(3), (4096,), dtype=jnp.float64)
    lengths, sems = blocking_analysis(x, min_blocks=64)
    assert lengths[0] == 1 and np.all(np.diff(lengths) > 0)
    exact = 1 / np.sqrt(4096)
    for length, sem in zip(lengths, np.asarray(sems), strict=True):
        n = 4096 // length
        assert abs(sem / exact - 1) < 4 / np.sqrt(2 * (n - 1))


@pytest.mark.parametrize(
    "kwargs",
    [
        {"series": np.arange(10.0), "n_blocks": 1},
        {"series": np.arange(10.0), "n_blocks": 11},
        {"series": np.arange(10), "n_blocks": 2},
        {"series": np.float64(1.0), "n_blocks": 2},
    ],
)
def test_block_average_bad_input(kwargs):
    with pytest.raises(ValueError):
        block_average(**kwargs)
