"""Multiple-tau correlator (Ramírez et al., J. Chem. Phys. 133, 154103 (2010)) against
direct (brute-force) correlations: exact at level 0; at coarse levels exactly the direct
correlation of the block means (autocorrelation mode) or of the subsampled signal (MSD
mode); statistically the analytic coarse-grained correlation of an AR(1) signal, and
unbiased MSDs of Brownian, Ornstein–Uhlenbeck and ballistic signals at every level."""

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from jaxdpd.analysis.dynamics import time_msd
from jaxdpd.observables import correlator

POINTS, AVERAGING, LEVELS = 8, 2, 4
# One jitted function for the whole file, so equal shapes compile once.
update_many = jax.jit(correlator.update_many)


def run(samples, mode, dtype=jnp.float64):
    state = correlator.init(samples.shape[1:], LEVELS, POINTS, AVERAGING, mode=mode, dtype=dtype)
    return correlator.result(update_many(state, jnp.asarray(samples, dtype)))


def direct(series, lag, mode):
    """Direct estimator over all origins: mean_t f(x(t), x(t + lag))."""
    later, earlier = series[lag:], series[: len(series) - lag]
    return (later * earlier if mode == "autocorrelation" else (later - earlier) ** 2).mean(axis=0)


def block_means(series, width):
    blocks = len(series) // width
    return series[: blocks * width].reshape((blocks, width) + series.shape[1:]).mean(axis=1)


def subsample(series, width):
    """Every width-th sample, the last of each complete block (what MSD mode passes up)."""
    return series[width - 1 :: width]


@pytest.mark.parametrize("mode", correlator.MODES)
def test_levels_equal_direct_correlations_of_compressed_series(mode):
    """Level 0 is the direct estimator at lags 0 .. p-1 (to round-off); level l >= 1 is,
    by construction, the direct estimator at block lags p/m .. p-1 on the series of
    means of 2^l consecutive samples (autocorrelation mode) or on every 2^l-th sample
    (MSD mode).  Signal: a random walk (MSD mode) or white noise."""
    rng = np.random.default_rng(3)
    noise = rng.normal(size=(300, 2, 3))
    series = np.cumsum(noise, axis=0) if mode == "msd" else noise
    lags, values = run(series, mode)
    np.testing.assert_array_equal(lags, correlator.lags(LEVELS, POINTS, AVERAGING))
    for index, lag in enumerate(lags[:POINTS]):
        np.testing.assert_allclose(values[index], direct(series, lag, mode), rtol=1e-12, atol=1e-12)
    for level in range(1, LEVELS):
        width = AVERAGING**level
        compress = block_means if mode == "autocorrelation" else subsample
        coarse = compress(series, width)
        for j in range(POINTS // AVERAGING, POINTS):
            index = int(np.flatnonzero(lags == j * width)[0])
            np.testing.assert_allclose(
                values[index], direct(coarse, j, mode), rtol=1e-12, atol=1e-12
            )


def test_coarse_levels_match_ar1_correlation_within_coarse_graining_error():
    """AR(1) x_t = rho x_{t-1} + sqrt(1 - rho^2) e_t, rho = exp(-1/tau): C(d) = rho^d.
    Means of w samples at block distance j (lag d = j w >= w) correlate exactly as
    C(d) K_w, K_w = sinh^2(w/2tau) / (w^2 sinh^2(1/2tau)) = 1 + (w^2 - 1)/(12 tau^2) + ...
    (module docstring).  64 independent channels give the standard error (scatter over
    channels / 8); checks allow 4 standard errors, on lags with C(d) > 0.05.  Run in
    float32 (sums of 4096 O(1) products: round-off ~1e-4, far below the errors)."""
    tau, channels, length = 20.0, 64, 4096
    rho = np.exp(-1 / tau)
    rng = np.random.default_rng(8)
    kicks = rng.normal(size=(length, channels)) * np.sqrt(1 - rho**2)
    signal = np.empty((length, channels))
    signal[0] = rng.normal(size=channels)
    for t in range(1, length):
        signal[t] = rho * signal[t - 1] + kicks[t]
    levels = 6
    state = correlator.init((channels,), levels, 16, AVERAGING, dtype=jnp.float32)
    state = update_many(state, jnp.asarray(signal, jnp.float32))
    lags, values = correlator.result(state)
    assert values.dtype == jnp.float32
    width = np.ones(len(lags))
    for level in range(1, levels):
        width[16 + (level - 1) * 8 : 16 + level * 8] = AVERAGING**level
    values = np.asarray(values)
    estimate, error = values.mean(axis=1), values.std(axis=1, ddof=1) / np.sqrt(channels)
    exact = rho**lags
    factor = np.sinh(width / (2 * tau)) ** 2 / (width**2 * np.sinh(1 / (2 * tau)) ** 2)
    resolvable = exact > 0.05
    z = (estimate - exact * factor)[resolvable] / error[resolvable]
    assert np.all(np.abs(z) < 4), z
    # On the resolvable lags the blocks are at most w = 4 wide, so the coarse-graining
    # bias K_w - 1 <= 15/(12 tau^2) = 0.3 per cent: the coarse levels estimate the true
    # C(d) = rho^d itself within the same statistical error.
    assert np.all(factor[resolvable] - 1 < 15 / (12 * tau**2) * 1.01)
    assert np.all(np.abs(estimate - exact)[resolvable] < 4 * error[resolvable])


MSD_LEVELS, MSD_POINTS, MSD_LENGTH, MSD_CHANNELS = 8, 16, 4096, 512


def msd_estimates(series):
    """Multiple-tau MSD (16 points, m = 2, 8 levels: lags to 1920) of ``(T, channels)``
    in float64, with the exact all-origins FFT MSD of the same data at the same lags."""
    state = correlator.init(series.shape[1:], MSD_LEVELS, MSD_POINTS, AVERAGING, mode="msd")
    lags, values = correlator.result(update_many(state, jnp.asarray(series)))
    exact = np.asarray(time_msd(jnp.asarray(series)))[lags]
    return lags, np.asarray(values), exact


def within_errors(values, reference):
    """|channel mean - reference| < 4 standard errors of the channel mean, at each lag
    (the channels are independent; ``reference`` is a formula or per-channel values, in
    which case the paired difference is tested)."""
    if np.ndim(reference) == 1:
        reference = reference[:, None]
    difference = values - reference
    error = difference.std(axis=1, ddof=1) / np.sqrt(difference.shape[1])
    z = difference.mean(axis=1) / error
    return np.abs(z) < 4, z


def test_msd_of_brownian_motion_is_unbiased_at_every_level():
    """Random walk with unit step variance: MSD(d) = d exactly (Einstein).  512 independent
    walks of 4096 steps; each coarse lag is checked against d, and against the exact
    FFT MSD of the same walks (paired), within 4 standard errors of the channel mean.
    Block means would give d - (w^2 - 1)/(3w), 2-4 per cent low at lags 8w..15w, about
    5 standard errors at the middle levels: this test fails for that estimator."""
    rng = np.random.default_rng(11)
    walks = np.cumsum(rng.normal(size=(MSD_LENGTH, MSD_CHANNELS)), axis=0)
    lags, values, exact = msd_estimates(walks)
    coarse = lags > 0
    ok, z = within_errors(values[coarse], lags[coarse].astype(float))
    assert ok.all(), dict(zip(lags[coarse][~ok], z[~ok], strict=True))
    ok, z = within_errors(values[coarse], exact[coarse])
    assert ok.all(), dict(zip(lags[coarse][~ok], z[~ok], strict=True))


def test_msd_of_bounded_ornstein_uhlenbeck_signal_is_unbiased_at_every_level():
    """AR(1) with unit variance and tau = 50 samples (as g2 of a chain): MSD(d) =
    2 (1 - exp(-d/tau)).  Checked against that and against the paired FFT MSD, within
    4 standard errors; block means were 11 per cent low at d = 128 and 32 per cent at
    d = 512 (they drop the blocks' internal variance from the plateau)."""
    tau = 50.0
    rho = np.exp(-1 / tau)
    rng = np.random.default_rng(12)
    signal = np.empty((MSD_LENGTH, MSD_CHANNELS))
    signal[0] = rng.normal(size=MSD_CHANNELS)
    kicks = rng.normal(size=(MSD_LENGTH, MSD_CHANNELS)) * np.sqrt(1 - rho**2)
    for t in range(1, MSD_LENGTH):
        signal[t] = rho * signal[t - 1] + kicks[t]
    lags, values, exact = msd_estimates(signal)
    coarse = lags > 0
    ok, z = within_errors(values[coarse], 2 * (1 - rho ** lags[coarse]))
    assert ok.all(), dict(zip(lags[coarse][~ok], z[~ok], strict=True))
    ok, z = within_errors(values[coarse], exact[coarse])
    assert ok.all(), dict(zip(lags[coarse][~ok], z[~ok], strict=True))


def test_msd_of_ballistic_motion_is_exact_at_every_level():
    """x(t) = x0 + v t: every displacement over lag d is v d, so MSD(d) = v^2 d^2 at every
    lag and level, to float64 round-off."""
    rng = np.random.default_rng(13)
    start, velocity = rng.normal(size=(2, 4, 3))
    times = np.arange(MSD_LENGTH, dtype=float)[:, None, None]
    lags, values, _ = msd_estimates(start + velocity * times)
    expected = velocity[None] ** 2 * lags[:, None, None].astype(float) ** 2
    np.testing.assert_allclose(values, expected, rtol=1e-9, atol=1e-9)


def test_chunks_and_vmap_agree():
    """Feeding two chunks equals the direct MSD of the whole series at level 0 (the engine
    feeds chunk after chunk); a vmap over replicas equals separate runs."""
    rng = np.random.default_rng(4)
    series = np.cumsum(rng.normal(size=(600, 2, 3)), axis=0)
    state = correlator.init((2, 3), LEVELS, POINTS, AVERAGING, mode="msd")
    chunked = update_many(update_many(state, series[:300]), series[300:])
    lags, values = correlator.result(chunked)
    for index, lag in enumerate(lags[:POINTS]):
        np.testing.assert_allclose(values[index], direct(series, lag, "msd"), rtol=1e-12)
    replicas = jax.vmap(update_many, in_axes=(None, 0))(
        state, jnp.stack([series[:300], 2 * series[:300]])
    )
    single = update_many(state, series[:300])
    np.testing.assert_allclose(replicas.correlation[0], single.correlation, rtol=1e-12)
    np.testing.assert_allclose(replicas.correlation[1], 4 * single.correlation, rtol=1e-12)
    # Lags not reached yet are NaN, never a silent zero.
    assert np.isnan(correlator.result(state)[1]).all()


def test_bad_arguments_are_refused():
    with pytest.raises(ValueError, match="points_per_level must be a multiple"):
        correlator.init((3,), 3, points_per_level=9, averaging=2)
    with pytest.raises(ValueError, match="mode"):
        correlator.init((3,), 3, mode="cross")
    with pytest.raises(ValueError, match="levels"):
        correlator.init((3,), 0)
    with pytest.raises(ValueError, match="dtype"):
        correlator.init((3,), 2, dtype=jnp.int32)
    state = correlator.init((3,), 2)
    with pytest.raises(ValueError, match="sample must have shape"):
        correlator.update(state, jnp.zeros(4))
    with pytest.raises(ValueError, match="samples must have shape"):
        correlator.update_many(state, jnp.zeros((5, 4)))
