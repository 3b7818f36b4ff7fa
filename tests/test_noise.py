"""Counter-based pair noise: symmetry, determinism, moments."""

import jax.numpy as jnp
import numpy as np

from jaxdpd.engine import noise


def test_pair_noise_is_symmetric_and_depends_only_on_the_counters():
    i = jnp.arange(1000, dtype=jnp.int32)
    j = jnp.flip(i) + 5
    key = noise.step_key(11, 3)
    a = noise.pair_uniform_unit_variance(key, i, j, jnp.float64)
    b = noise.pair_uniform_unit_variance(key, j, i, jnp.float64)
    np.testing.assert_array_equal(a, b)
    # Order of evaluation does not matter: a permuted batch gives permuted values.
    perm = np.random.default_rng(0).permutation(1000)
    c = noise.pair_uniform_unit_variance(key, i[perm], j[perm], jnp.float64)
    np.testing.assert_array_equal(c, a[perm])
    # Another step or seed gives different numbers.
    d = noise.pair_uniform_unit_variance(noise.step_key(11, 4), i, j, jnp.float64)
    e = noise.pair_uniform_unit_variance(noise.step_key(12, 3), i, j, jnp.float64)
    assert np.mean(a == d) < 0.01 and np.mean(a == e) < 0.01


def test_uniform_and_gaussian_moments():
    """Mean 0, variance 1 and the right fourth moment (uniform on [−√3, √3]: 9/5;
    Gaussian: 3), within 5 standard errors of the sample estimates."""
    n = 400_000
    i = jnp.arange(n, dtype=jnp.int32)
    j = i + n
    key = noise.step_key(1, 0)
    for draw, kurtosis in (
        (noise.pair_uniform_unit_variance, 9 / 5),
        (noise.pair_gaussian, 3.0),
    ):
        x = np.asarray(draw(key, i, j, jnp.float64))
        for moment, expected in ((1, 0.0), (2, 1.0), (4, kurtosis)):
            values = x**moment
            error = values.std() / np.sqrt(n)
            assert abs(values.mean() - expected) < 5 * error, (draw.__name__, moment)


def test_neighbouring_counters_are_uncorrelated():
    """Lag-1 correlation over consecutive pair indices and steps: |ρ| < 5/√n."""
    n = 200_000
    i = jnp.zeros(n, jnp.int32)
    j = jnp.arange(1, n + 1, dtype=jnp.int32)
    x = np.asarray(noise.pair_uniform_unit_variance(noise.step_key(5, 0), i, j, jnp.float64))
    y = np.asarray(noise.pair_uniform_unit_variance(noise.step_key(5, 1), i, j, jnp.float64))
    for a, b in ((x[1:], x[:-1]), (x, y)):
        assert abs(np.corrcoef(a, b)[0, 1]) < 5 / np.sqrt(n)
