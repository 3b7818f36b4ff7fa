"""Chain dynamics: mean-square displacements g1, g2, g3, positional autocorrelation,
centre-of-mass velocity autocorrelation and the centre-of-mass diffusion coefficient.

Definitions (Ahlrichs & Dünweg, J. Chem. Phys. 111, 8225 (1999), eqs. 33-35;
Mussawisade et al., J. Chem. Phys. 123, 144905 (2005), eq. 17 and Fig. 4):

    g1(t) = < |r_i(t0 + t) - r_i(t0)|^2 >                         (bead),
    g2(t) = < |u_i(t0 + t) - u_i(t0)|^2 >,  u_i = r_i - r_cm       (bead relative to CM),
    g3(t) = < |r_cm(t0 + t) - r_cm(t0)|^2 >                       (centre of mass),

averaged over time origins ``t0`` and beads.  The positional autocorrelation is

    C(t) = < sum_i u_i(t0 + t) . u_i(t0) > / < sum_i |u_i|^2 >,

the normalised autocorrelation of the bead positions relative to the centre of mass.
With the Rouse modes ``X_p`` of :mod:`jaxdpd.analysis.conformation`
(``u_n = 2 sum_{p>=1} X_p cos(p pi (n - 1/2)/N)``) it is exactly
``C(t) = sum_{p>=1} <X_p(t0 + t) . X_p(t0)> / sum_{p>=1} <X_p^2>``, the sum of the
Rouse-mode autocorrelations weighted by their amplitudes; this is the quantity the
Rouse–Zimm model of :func:`jaxdpd.analysis.fits.rouse_zimm_correlation` describes.
(Clarke's thesis as available in ``shared/seeds`` defines no positional
autocorrelation; the definition above is the one the Rouse-mode analyses of Ahlrichs &
Dünweg and Mussawisade et al. imply.)

Two ways to compute them:

- from a stored trajectory (time on axis 0): ``bead_msd``, ``relative_bead_msd``,
  ``center_of_mass_msd``, ``positional_autocorrelation``, ``center_of_mass_vacf``,
  exact for every lag ``0 .. T-1`` by FFT (``O(T log T)``), averaged over all origins;
- on device while the simulation runs: feed :func:`displacement_samples` to the
  multiple-tau correlator (:mod:`jaxdpd.observables.correlator`, mode ``"msd"`` for
  g1, g2, g3, mode ``"autocorrelation"`` of the ``"g2"`` sample ``u_i`` for ``C(t)``)
  and reduce its result with :func:`average_over_elements`, or
  :func:`normalized_correlation` for ``C(t)`` (the "dynamics" observable,
  :mod:`jaxdpd.observables.chain_correlators`, does this during a run).

All functions are pure ``jax.numpy`` (jittable) except :func:`diffusion_coefficient`,
an analysis step returning Python floats.
"""

from __future__ import annotations

import jax
import jax.numpy as jnp
import numpy as np

from jaxdpd.analysis._checks import chain_positions, floating_array, positive_int
from jaxdpd.analysis.statistics import block_average

__all__ = [
    "average_over_elements",
    "bead_msd",
    "center_of_mass_msd",
    "center_of_mass_vacf",
    "diffusion_coefficient",
    "displacement_samples",
    "normalized_correlation",
    "positional_autocorrelation",
    "relative_bead_msd",
    "time_autocorrelation",
    "time_msd",
]


def displacement_samples(chains):
    """Per-sample inputs of the on-device MSD correlator.

    Args:
      chains: ``(n_chains, n_beads, 3)`` unwrapped positions at one time.

    Returns:
      dict ``{"g1": (n_chains, n_beads, 3) positions, "g2": (n_chains, n_beads, 3)
      positions relative to the chain's centre of mass, "g3": (n_chains, 3) centres of
      mass}``; correlate each with mode ``"msd"`` and reduce with
      :func:`average_over_elements`.
    """
    x = chain_positions(chains, min_beads=1)
    center = x.mean(axis=-2)
    return {"g1": x, "g2": x - center[..., None, :], "g3": center}


def average_over_elements(correlation):
    """Reduce an elementwise correlator result ``(K, ..., 3)`` to ``(K,)``.

    Sums the Cartesian (last) axis and averages the axes in between (beads, chains):
    ``g(t) = mean_elements sum_d c_d(t)``, or ``<A(t0) . A(t0 + t)>`` in
    autocorrelation mode.
    """
    c = floating_array(correlation, "correlation", min_ndim=2)
    summed = c.sum(axis=-1)
    return summed.reshape(summed.shape[0], -1).mean(axis=1)


@jax.jit
def _lagged_products(series):
    """``sum_{t=0}^{T-1-k} x(t) x(t+k)`` for k = 0 .. T-1 (elementwise), by FFT."""
    length = series.shape[0]
    size = 1 << (2 * length - 1).bit_length()
    spectrum = jnp.fft.rfft(series, n=size, axis=0)
    products = jnp.fft.irfft(spectrum * jnp.conj(spectrum), n=size, axis=0)[:length]
    return products.astype(series.dtype)


def _origins(length: int, ndim: int, dtype):
    counts = jnp.arange(length, 0, -1, dtype=dtype)
    return counts.reshape((length,) + (1,) * (ndim - 1))


def _time_series(series, name: str):
    x = floating_array(series, name)
    if x.shape[0] < 2:
        raise ValueError(f"{name} needs at least 2 times on axis 0, got shape {x.shape}")
    return x


def time_autocorrelation(series):
    """``<x(t0) x(t0 + k)>`` over all origins, elementwise, for every lag.

    Args:
      series: ``(T, ...)`` with time on axis 0 (equally spaced samples).

    Returns:
      ``(T, ...)``: entry ``k`` is ``(1/(T - k)) sum_{t=0}^{T-1-k} x(t) x(t + k)``.
    """
    return _autocorrelation(_time_series(series, "series"))


@jax.jit
def _autocorrelation(x):
    return _lagged_products(x) / _origins(x.shape[0], x.ndim, x.dtype)


def time_msd(series):
    """``<(x(t0 + k) - x(t0))^2>`` over all origins, elementwise, for every lag.

    Uses ``sum_t (x(t+k) - x(t))^2 = sum_{t<T-k} x(t)^2 + sum_{t>=k} x(t)^2 -
    2 sum_t x(t) x(t+k)``, the last term by FFT (Kneller et al., Comput. Phys. Commun.
    91, 191 (1995)).  The time mean is subtracted first to limit round-off.

    Args:
      series: ``(T, ...)`` with time on axis 0 (unwrapped coordinates).

    Returns:
      ``(T, ...)``: entry ``k`` is the MSD at lag ``k`` (entry 0 is 0).
    """
    return _msd(_time_series(series, "series"))


@jax.jit
def _msd(x):
    x = x - x.mean(axis=0)
    length = x.shape[0]
    squares = x**2
    partial = jnp.concatenate([jnp.zeros_like(squares[:1]), jnp.cumsum(squares, axis=0)])
    head = partial[::-1][:length]  # sum_{t < T-k} x(t)^2
    tail = partial[length] - partial[:length]  # sum_{t >= k} x(t)^2
    sums = head + tail - 2 * _lagged_products(x)
    return jnp.maximum(sums, 0) / _origins(length, x.ndim, x.dtype)


def _trajectory(trajectory):
    x = chain_positions(trajectory, "trajectory", min_beads=1)
    if x.ndim != 4:
        raise ValueError(
            f"trajectory must have shape (T, n_chains, n_beads, 3), got {trajectory.shape}"
        )
    return _time_series(x, "trajectory")


def bead_msd(trajectory):
    """g1 per chain: bead MSD averaged over the chain's beads.

    Args:
      trajectory: ``(T, n_chains, n_beads, 3)`` unwrapped positions, equal spacing.

    Returns:
      ``(T, n_chains)`` (units r_c^2); lag ``k`` on axis 0.  Average over axis 1 for
      g1; the chains are the samples for an error bar.
    """
    return _msd(_trajectory(trajectory)).sum(axis=-1).mean(axis=-1)


def relative_bead_msd(trajectory):
    """g2 per chain: MSD of the bead positions relative to the chain's centre of mass.

    Args and Returns as :func:`bead_msd`.
    """
    x = _trajectory(trajectory)
    return _msd(x - x.mean(axis=-2, keepdims=True)).sum(axis=-1).mean(axis=-1)


def center_of_mass_msd(trajectory):
    """g3 per chain: MSD of the chain's centre of mass, ``(T, n_chains)``.

    Args as :func:`bead_msd`.
    """
    return _msd(_trajectory(trajectory).mean(axis=-2)).sum(axis=-1)


def positional_autocorrelation(trajectory):
    """Normalised positional autocorrelation ``C(t)`` (see module docstring) with errors.

    ``C(k) = sum_c S_c(k) / sum_c S_c(0)`` with ``S_c(k) = <sum_i u_i(t0+k) . u_i(t0)>_t0``
    for chain ``c`` (a ratio of averages, so no per-chain normalisation bias), and its
    jackknife error over the chains (:func:`normalized_correlation`).

    Args:
      trajectory: ``(T, n_chains, n_beads, 3)`` unwrapped positions, equal spacing; one
        chain or more.

    Returns:
      ``(C, C_error)``: two ``(T,)`` arrays; ``C[0] = 1`` and ``C_error[0] = 0``;
      ``C_error`` is NaN for a single chain (no samples to estimate it from).
    """
    x = _trajectory(trajectory)
    relative = x - x.mean(axis=-2, keepdims=True)
    return normalized_correlation(_autocorrelation(relative).sum(axis=(-2, -1)))


def normalized_correlation(per_chain):
    """``C(k) = sum_c S_c(k) / sum_c S_c(0)`` and its jackknife error over the chains.

    The error is the leave-one-chain-out jackknife (Efron & Stein, Ann. Stat. 9, 586
    (1981)): with ``C_(c)`` the ratio without chain ``c``,
    ``sigma^2 = ((n - 1)/n) sum_c (C_(c) - mean_c C_(c))^2``, treating the chains as
    independent samples.

    Args:
      per_chain: ``(K, n_chains)`` unnormalised correlations ``S_c(k)`` of each chain
        (e.g. ``sum_i <u_i(t0 + k) . u_i(t0)>``, units r_c^2), lag ``k`` on axis 0 with
        lag 0 first; NaN where a lag has not been reached (on-device correlators).

    Returns:
      ``(C, C_error)``: two ``(K,)`` arrays; ``C_error`` is NaN for a single chain.
    """
    s = floating_array(per_chain, "per_chain", min_ndim=2)
    if s.ndim != 2:
        raise ValueError(f"per_chain must have shape (K, n_chains), got {s.shape}")
    return _normalized_correlation(s)


@jax.jit
def _normalized_correlation(per_chain):
    n_chains = per_chain.shape[1]
    total = per_chain.sum(axis=1)
    correlation = total / total[0]
    if n_chains < 2:
        return correlation, jnp.full_like(correlation, jnp.nan)
    left_out = (total[:, None] - per_chain) / (total[0] - per_chain[0])
    spread = jnp.sum((left_out - left_out.mean(axis=1, keepdims=True)) ** 2, axis=1)
    return correlation, jnp.sqrt((n_chains - 1) / n_chains * spread)


def center_of_mass_vacf(velocities):
    """Centre-of-mass velocity autocorrelation per chain.

    Args:
      velocities: ``(T, n_chains, n_beads, 3)`` bead velocities (units r_c/time).

    Returns:
      ``(T, n_chains)``: ``<V_cm(t0) . V_cm(t0 + k)>`` with ``V_cm = (1/N) sum_i v_i``;
      Mussawisade et al. Fig. 1 (long-time tail ``~ t^(-3/2)``).
    """
    return _autocorrelation(_trajectory(velocities).mean(axis=-2)).sum(axis=-1)


def diffusion_coefficient(
    times, msd, fit_from: float, n_blocks: int | None = None, dimension: int = 3
):
    """Diffusion coefficient from the long-time slope of an MSD, with an error bar.

    For each sample ``k`` (an independent chain, replica or trajectory segment) the
    slope ``s_k`` of a straight line ``msd = s t + c`` fitted by least squares to the
    points with ``t >= fit_from`` gives ``D_k = s_k / (2 d)`` (Einstein; thesis eq. 3.7
    with ``d = 3``: ``D = g3/(6t)`` at long times; the intercept absorbs the
    short-time, non-diffusive part).  The estimate is the mean of ``D_k`` and its
    standard error comes from block averages over the samples
    (:func:`jaxdpd.analysis.statistics.block_average`), so it accounts for the correlation
    between the points of one MSD curve.

    Args:
      times: ``(K,)`` lag times (e.g. ``lags * dt``), increasing.
      msd: ``(K, n_samples)`` MSD curves, e.g. :func:`center_of_mass_msd` (per chain).
        The samples must be (nearly) independent: chains of a dilute solution or
        separate replicas.  Chains in one periodic box are coupled by hydrodynamics
        and momentum conservation; prefer replicas when that matters.
      fit_from: smallest time used in the fit, beyond the longest relaxation time.
      n_blocks: blocks of samples for the error; default ``min(n_samples, 20)``.
      dimension: ``d``, the number of Cartesian components summed in ``msd``.

    Returns:
      ``(D, D_error)`` as Python floats (units r_c^2/time).
    """
    t = np.asarray(times, dtype=np.float64)
    g = np.asarray(msd, dtype=np.float64)
    if t.ndim != 1 or g.ndim != 2 or g.shape[0] != t.shape[0]:
        raise ValueError(f"times must be (K,) and msd (K, n_samples); got {t.shape} and {g.shape}")
    if g.shape[1] < 2:
        raise ValueError(f"msd needs at least 2 samples for an error bar, got {g.shape[1]}")
    dimension = positive_int(dimension, "dimension")
    used = t >= fit_from
    if used.sum() < 2:
        raise ValueError(f"fit_from={fit_from!r} leaves fewer than 2 times to fit")
    t_used = t[used] - t[used].mean()
    slopes = t_used @ (g[used] - g[used].mean(axis=0)) / (t_used @ t_used)
    blocks = min(g.shape[1], 20) if n_blocks is None else n_blocks
    mean, error = block_average(slopes / (2 * dimension), n_blocks=blocks)
    return float(mean), float(error)
