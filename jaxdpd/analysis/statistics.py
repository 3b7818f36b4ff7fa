"""Error bars for correlated time series: block averages and the blocking analysis.

A time series ``x_1 .. x_T`` of a stationary, correlated observable is cut into
``n_blocks`` contiguous blocks of equal length.  When each block is much longer than
the integrated autocorrelation time, the block means are nearly independent, and the
standard error of the overall mean is the standard deviation of the block means over
``sqrt(n_blocks)``:

    mean = (1/n_b) sum_k m_k,    sem = sqrt( sum_k (m_k - mean)^2 / (n_b (n_b - 1)) ).

The blocking (renormalisation) analysis of Flyvbjerg & Petersen, J. Chem. Phys. 91,
461 (1989), halves the series repeatedly; the naive standard error of the blocked
series rises and then plateaus at the true standard error once blocks are longer than
the correlation time.  The relative uncertainty of a standard error estimated from
``n_b`` blocks is about ``1/sqrt(2 (n_b - 1))``.

All functions are pure ``jax.numpy``: they accept NumPy or JAX arrays, keep the input
floating dtype, and may be called under ``jit`` (``n_blocks`` and ``axis`` are static).
"""

from __future__ import annotations

import jax.numpy as jnp
import numpy as np

from jaxdpd.precision import as_array

__all__ = [
    "block_average",
    "blocking_analysis",
    "blocking_plateau",
    "relative_error_of_error",
    "inverse_variance_mean",
    "ratio_of_means",
]


def _check_series(series, axis: int, n_blocks: int | None = None):
    x = as_array(series)
    if not jnp.issubdtype(x.dtype, jnp.floating):
        raise ValueError(
            f"series must hold floating-point values, got dtype {x.dtype}; "
            "convert explicitly (e.g. x.astype(jnp.float64))"
        )
    if x.ndim == 0:
        raise ValueError("series must have at least one axis (time), got a scalar")
    if not -x.ndim <= axis < x.ndim:
        raise ValueError(f"axis={axis} is out of range for a series of shape {x.shape}")
    x = jnp.moveaxis(x, axis, 0)
    if n_blocks is not None:
        if not isinstance(n_blocks, int | np.integer) or n_blocks < 2:
            raise ValueError(f"n_blocks must be an integer >= 2, got {n_blocks!r}")
        if x.shape[0] < n_blocks:
            raise ValueError(
                f"n_blocks={n_blocks} exceeds the series length {x.shape[0]} along axis {axis}"
            )
    return x


def block_average(series, n_blocks: int = 20, axis: int = 0):
    """Mean and standard error of a correlated series from block averages.

    Args:
      series: array of shape ``(..., T, ...)`` with the time axis at ``axis``; floating
        dtype (float32 or float64, kept).  Units: those of the observable.
      n_blocks: number of contiguous blocks (>= 2).  Samples beyond
        ``n_blocks * (T // n_blocks)`` at the *start* of the series are discarded
        (the start is the least equilibrated part).
      axis: the time axis.

    Returns:
      ``(mean, sem)``: arrays of the series shape with ``axis`` removed; ``sem`` is the
      standard error of the mean, ``std(block means, ddof=1) / sqrt(n_blocks)``.

    Reference: Flyvbjerg & Petersen, J. Chem. Phys. 91, 461 (1989); Allen & Tildesley,
    *Computer Simulation of Liquids*, 2nd ed. (2017), ch. 8 (block averages).
    """
    x = _check_series(series, axis, n_blocks)
    length = x.shape[0] // n_blocks
    x = x[x.shape[0] - n_blocks * length :]
    blocks = x.reshape((n_blocks, length) + x.shape[1:]).mean(axis=1)
    mean = blocks.mean(axis=0)
    sem = jnp.sqrt(jnp.sum((blocks - mean) ** 2, axis=0) / (n_blocks * (n_blocks - 1)))
    return mean, sem


def blocking_analysis(series, axis: int = 0, min_blocks: int = 8):
    """Flyvbjerg–Petersen blocking: standard error of the mean against block length.

    Args:
      series: array ``(..., T, ...)`` with time at ``axis``, floating dtype.
      axis: the time axis.
      min_blocks: stop halving when fewer than this many blocks would remain (>= 2).

    Returns:
      ``(block_lengths, sems)``: a NumPy int array ``(L,)`` of block lengths
      ``1, 2, 4, ...`` and an array ``(L, ...)`` of the naive standard error of the
      mean of the blocked series at each length.  A plateau in ``sems`` is the
      standard error; no plateau means the series is too short for its correlation
      time.

    Reference: Flyvbjerg & Petersen, J. Chem. Phys. 91, 461 (1989).
    """
    if not isinstance(min_blocks, int | np.integer) or min_blocks < 2:
        raise ValueError(f"min_blocks must be an integer >= 2, got {min_blocks!r}")
    x = _check_series(series, axis)
    lengths, sems = [], []
    length = 1
    while x.shape[0] >= min_blocks:
        n = x.shape[0]
        var = jnp.var(x, axis=0, ddof=1)
        sems.append(jnp.sqrt(var / n))
        lengths.append(length)
        x = x[n % 2 :]
        x = 0.5 * (x[0::2] + x[1::2])
        length *= 2
    return np.asarray(lengths, dtype=np.int64), jnp.stack(sems)


# Fewest blocks of a blocking level that may decide the plateau: the standard error
# from n blocks is itself uncertain by 1/sqrt(2 (n − 1)), 18 % at n = 16.
DECIDING_BLOCKS = 16


def relative_error_of_error(n_blocks):
    """Relative standard deviation 1/sqrt(2 (n − 1)) of a standard error estimated from
    `n_blocks` independent block means (Flyvbjerg & Petersen 1989, eq. 28)."""
    return 1 / np.sqrt(2 * (np.asarray(n_blocks, np.float64) - 1))


def blocking_plateau(series, min_blocks: int = 8):
    """The block length at which a scalar series' blocking analysis reaches its plateau.

    The criterion of Lee, Conduit, Nemec, López Ríos & Drummond, Phys. Rev. E 83,
    066706 (2011), eq. (14): the shortest block length B of `blocking_analysis` with

        B³ > 2 T (s_B / s_1)⁴,

    s_B the standard error at block length B, T the number of samples.  (s_B/s_1)²
    estimates the statistical inefficiency 2 τ_int; the inequality keeps the bias of
    blocks of length B (∝ τ_int/B) below the statistical error of the error
    (∝ sqrt(B/T)).  Only levels of at least DECIDING_BLOCKS blocks may meet it: s_B
    from n blocks is uncertain by 1/sqrt(2 (n − 1)), and the last levels' few blocks
    (27 % at 8) let a downward fluctuation both pass the criterion and set the error.
    The longer levels are still computed (and drawn by `jaxdpd plot`); they decide
    nothing.

    Args:
      series: (T,) floating-point samples of one quantity.
      min_blocks: as for `blocking_analysis` (the longest blocks tried leave this many).

    Returns:
      ``(block_length, sem)`` at the plateau, or ``(None, largest sem of the deciding
      levels)`` when no deciding level satisfies the criterion: the series is too short
      for its correlation time and every error bar from it is a lower bound.
    """
    lengths, sems = blocking_analysis(series, min_blocks=min_blocks)
    sems = np.asarray(sems, np.float64)
    if sems.ndim != 1:
        raise ValueError(f"series must be one scalar per sample (T,), got shape {np.shape(series)}")
    samples = np.shape(series)[0]
    if sems[0] == 0:  # a constant series: every block length agrees
        return int(lengths[0]), 0.0
    deciding = samples // lengths >= min(DECIDING_BLOCKS, samples)
    reached = deciding & (lengths.astype(np.float64) ** 3 > 2 * samples * (sems / sems[0]) ** 4)
    if not reached.any():
        return None, float(sems[deciding].max())
    first = int(np.argmax(reached))
    return int(lengths[first]), float(sems[first])


def ratio_of_means(numerator, denominator, n_blocks: int = 20, axis: int = 0):
    """Ratio ``r = <a>/<b>`` of two series sampled together, with its standard error.

    The error is the block-average standard error of the linearised series
    ``(a_t - r b_t) / <b>`` (first-order delta method: it carries the correlation of
    ``a`` and ``b`` and their time correlations through the blocks), valid when the
    relative error of ``<b>`` is small.

    Args:
      numerator, denominator: arrays of one shape ``(..., T, ...)``, time at ``axis``.
      n_blocks: number of blocks (see :func:`block_average`).
      axis: the time axis.

    Returns:
      ``(ratio, sem)``: arrays of the series shape with ``axis`` removed.

    Reference: the delta method for a ratio of means (first-order error propagation,
    with the covariance of numerator and denominator kept).
    """
    a = _check_series(numerator, axis, n_blocks)
    b = _check_series(denominator, axis, n_blocks)
    if a.shape != b.shape:
        raise ValueError(f"numerator {a.shape} and denominator {b.shape} must have one shape")
    mean_a, _ = block_average(a, n_blocks)
    mean_b, _ = block_average(b, n_blocks)
    ratio = mean_a / mean_b
    _, sem = block_average((a - ratio * b) / mean_b, n_blocks)
    return ratio, jnp.abs(sem)


def inverse_variance_mean(means, errors, axis: int = 0):
    """Combined mean of independent estimates (e.g. replicas) and its standard error.

    Each estimate is weighted by 1/error², the minimum-variance unbiased combination:
    ``mean = Σ w_k m_k / Σ w_k`` and ``sem = 1/sqrt(Σ w_k)`` with ``w_k = 1/e_k²``.

    Args:
      means, errors: arrays of one shape; the estimates lie along ``axis``.
      axis: the axis that is combined.

    Returns:
      ``(mean, sem)``: arrays with ``axis`` removed.

    Reference: weighted averaging of independent measurements, e.g. Bevington &
    Robinson, *Data Reduction and Error Analysis for the Physical Sciences*, 3rd
    ed. (2003), ch. 4 (the weighted mean).
    """
    means, errors = as_array(means), as_array(errors)
    if means.shape != errors.shape:
        raise ValueError(f"means {means.shape} and errors {errors.shape} must have one shape")
    weights = 1 / errors**2
    total = jnp.sum(weights, axis=axis)
    return jnp.sum(weights * means, axis=axis) / total, 1 / jnp.sqrt(total)
