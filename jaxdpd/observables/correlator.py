"""Multiple-tau correlator: time correlations on the fly, on device, in fixed memory.

The algorithm of Ramírez, Sukumaran, Vorselaars & Likhtman, J. Chem. Phys. 133,
154103 (2010) ("Efficient on the fly calculation of time correlation functions in
computer simulations"), written as a pure, jittable pytree state.

Level 0 receives every sample.  Level ``l >= 1`` receives one value for every ``m``
values of level ``l - 1`` (``m = averaging``), i.e. one value per ``m^l`` samples.
Each level keeps the last ``p = points_per_level`` values in a ring buffer; a value
arriving at level ``l`` is correlated with itself and the ``p - 1`` values before it.
Level 0 gives lags ``0 .. p-1`` exactly (every pair of samples at those lags, the
direct estimator averaged over all time origins).  Level ``l >= 1`` gives lags
``j m^l`` for ``j = p/m .. p-1`` (the shorter lags are already covered by the level
below); the lags are contiguous across levels.  ``L`` levels reach a largest lag
``(p - 1) m^(L-1)`` samples with memory ``O(L p)`` per element, and cost ``O(L p)``
element operations per sample.

What a level passes up (its compression) depends on the mode:

- ``"autocorrelation"``: the mean of the ``m`` values (Ramírez et al.), so level ``l``
  holds block means of width ``w = m^l``.  For a correlation ``C(d)`` the block means
  give ``(1/w^2) sum_{a,b=0}^{w-1} C(d + b - a)``, which for ``C(d) = C_0 exp(-d/tau)``
  and ``d >= w`` is exactly ``C(d) sinh^2(w/2tau) / (w^2 sinh^2(1/2tau))
  = C(d) [1 + (w^2 - 1)/(12 tau^2) + ...]``.  Level ``l`` only serves lags
  ``d >= (p/m) w``, so the relative error at lag ``d`` is at most about
  ``(m d / p)^2 / (12 tau^2)``: with ``p/m = 8`` about 1 per cent at ``d = 3 tau``,
  where the correlation has decayed to 5 per cent.
- ``"msd"``: the latest of the ``m`` values (a subsample), so level ``l`` holds the
  signal itself at every ``w``-th sample and ``(A(t0 + j w) - A(t0))^2`` is an exact
  displacement: the estimate is unbiased at every lag, from time origins ``w`` apart
  (as many products as block means would give).  Block means are not usable here:
  for a random walk with step variance ``s^2`` the mean displacement of two blocks
  ``d >= w`` apart has ``E (mean_{a+j} - mean_a)^2 = s^2 [d - (w^2 - 1)/(3 w)]``, i.e.
  2-4 per cent low at lags ``8 w .. 15 w``, and a bounded signal's plateau is
  lowered by the blocks' internal variance.  ESPResSo's correlator makes the same
  choice for MSDs (``compress1="discard1"`` in its ``samples/diffusion_coefficient.py``).

Two modes, elementwise over the sample's shape:

- ``"autocorrelation"``: ``C(t) = < A(t0) A(t0 + t) >``;
- ``"msd"``: ``g(t) = < (A(t0 + t) - A(t0))^2 >`` (for the MSDs g1, g2, g3 feed the
  bead positions, the positions relative to the chain's centre of mass, or the centres
  of mass; sum the Cartesian axis and average over beads/chains afterwards).

Dot products (``A . B``) are the sum over the Cartesian axis of the elementwise result.
Sums are accumulated in the sample dtype.  A float32 sum of ``n`` products carries a
relative round-off of up to ``n * 6e-8`` (typically ``sqrt(n) * 6e-8``), i.e. up to
0.6 per cent after 1e5 samples at level 0; use float64 for long runs.

Usage::

    state = init((n_chains, 3), levels=12)
    state = jax.jit(update_many)(state, chunk_of_samples)   # (n_steps, n_chains, 3)
    lags, g3 = result(state)                                # lags in sample intervals
"""

from __future__ import annotations

import dataclasses
from functools import partial

import jax
import jax.numpy as jnp
import numpy as np

from jaxdpd.analysis._checks import positive_int

__all__ = ["MODES", "MultipleTauState", "init", "lags", "result", "update", "update_many"]

MODES = ("autocorrelation", "msd")


@jax.tree_util.register_dataclass
@dataclasses.dataclass(frozen=True)
class MultipleTauState:
    """State of a multiple-tau correlator (a pytree; ``averaging`` and ``mode`` static).

    Attributes:
      buffer: ``(L, p, *shape)`` ring buffers of the last ``p`` values of each level.
      inserted: ``(L,)`` int32, values inserted into each level so far.
      accumulator: ``(L, *shape)`` running sum of values waiting to be averaged into
        the next level (autocorrelation mode; stays zero in msd mode).
      accumulated: ``(L,)`` int32, how many values ``accumulator`` holds (< averaging).
      correlation: ``(L, p, *shape)`` sums of the correlated products per level and
        buffer distance ``j``.
      counts: ``(L, p)`` int32, number of products in each sum.
      averaging: ``m``, values averaged into one value of the next level.
      mode: ``"autocorrelation"`` or ``"msd"``.
    """

    buffer: jnp.ndarray
    inserted: jnp.ndarray
    accumulator: jnp.ndarray
    accumulated: jnp.ndarray
    correlation: jnp.ndarray
    counts: jnp.ndarray
    averaging: int = dataclasses.field(metadata=dict(static=True))
    mode: str = dataclasses.field(metadata=dict(static=True))

    @property
    def levels(self) -> int:
        return self.buffer.shape[0]

    @property
    def points_per_level(self) -> int:
        return self.buffer.shape[1]

    @property
    def sample_shape(self) -> tuple[int, ...]:
        return self.buffer.shape[2:]


def init(
    shape,
    levels: int,
    points_per_level: int = 16,
    averaging: int = 2,
    mode: str = "autocorrelation",
    dtype=jnp.float64,
) -> MultipleTauState:
    """An empty correlator for samples of shape ``shape``.

    Args:
      shape: shape of one sample (a tuple; ``()`` for a scalar signal).
      levels: ``L >= 1``; the largest lag is ``(p - 1) averaging^(L-1)`` samples.
      points_per_level: ``p``, ring-buffer length per level; a multiple of
        ``averaging`` and at least ``2 averaging`` (Ramírez et al. use 16).
      averaging: ``m >= 2`` values averaged into one of the next level (usually 2).
      mode: ``"autocorrelation"`` or ``"msd"`` (see the module docstring).
      dtype: float32 or float64, the dtype of samples and accumulated sums.

    Returns:
      A :class:`MultipleTauState` with all sums zero.
    """
    levels = positive_int(levels, "levels")
    averaging = positive_int(averaging, "averaging", minimum=2)
    points = positive_int(points_per_level, "points_per_level", minimum=2 * averaging)
    if points % averaging:
        raise ValueError(
            f"points_per_level must be a multiple of averaging={averaging}, got {points}"
        )
    if mode not in MODES:
        raise ValueError(f"mode must be one of {MODES}, got {mode!r}")
    dtype = np.dtype(dtype)
    if dtype not in (np.dtype(np.float32), np.dtype(np.float64)):
        raise ValueError(f"dtype must be float32 or float64, got {dtype}")
    try:
        shape = tuple(positive_int(s, "shape entries") for s in shape)
    except TypeError as err:
        raise ValueError(f"shape must be a tuple of positive integers, got {shape!r}") from err
    zeros_int = jnp.zeros((levels,), jnp.int32)
    return MultipleTauState(
        buffer=jnp.zeros((levels, points) + shape, dtype),
        inserted=zeros_int,
        accumulator=jnp.zeros((levels,) + shape, dtype),
        accumulated=zeros_int,
        correlation=jnp.zeros((levels, points) + shape, dtype),
        counts=jnp.zeros((levels, points), jnp.int32),
        averaging=averaging,
        mode=mode,
    )


def _broadcast_mask(mask, ndim: int):
    return mask.reshape(mask.shape + (1,) * (ndim - mask.ndim))


def update(state: MultipleTauState, sample) -> MultipleTauState:
    """Add one sample (shape ``state.sample_shape``); pure and jittable.

    The new value is pushed through the levels: every level it reaches correlates it
    with its buffer, and every ``averaging``-th value of a level sends a value up: the
    mean of the last ``averaging`` values (autocorrelation mode) or the value itself
    (msd mode; the module docstring says why).  Levels the value does not reach are left unchanged
    (masked, so the cost per sample is the same at every step).
    """
    sample = jnp.asarray(sample, state.buffer.dtype)
    if sample.shape != state.sample_shape:
        raise ValueError(
            f"sample must have shape {state.sample_shape} (the shape given to init), "
            f"got {sample.shape}"
        )
    points, m = state.points_per_level, state.averaging
    distances = jnp.arange(points)

    def level_step(carry, level_state):
        value, active = carry
        buffer, n_inserted, total, n_accumulated, correlation, counts, level = level_state
        position = n_inserted % points
        buffer = jnp.where(active, buffer.at[position].set(value), buffer)
        n_inserted = n_inserted + active.astype(jnp.int32)
        older = buffer[(position - distances) % points]
        if state.mode == "autocorrelation":
            products = value[None] * older
        else:
            products = (value[None] - older) ** 2
        first_distance = jnp.where(level == 0, 0, points // m)
        valid = active & (distances < n_inserted) & (distances >= first_distance)
        correlation = correlation + jnp.where(_broadcast_mask(valid, products.ndim), products, 0)
        counts = counts + valid.astype(jnp.int32)
        n_accumulated = n_accumulated + active.astype(jnp.int32)
        passes_up = n_accumulated == m
        if state.mode == "autocorrelation":
            total = total + jnp.where(active, value, 0)
            passed = total / m
        else:
            passed = value
        new_level = (
            buffer,
            n_inserted,
            jnp.where(passes_up, 0, total),
            jnp.where(passes_up, 0, n_accumulated),
            correlation,
            counts,
        )
        return (passed, passes_up), new_level

    levels = (
        state.buffer,
        state.inserted,
        state.accumulator,
        state.accumulated,
        state.correlation,
        state.counts,
        jnp.arange(state.levels),
    )
    _, new = jax.lax.scan(level_step, (sample, jnp.asarray(True)), levels)
    return MultipleTauState(*new, averaging=state.averaging, mode=state.mode)


def update_many(state: MultipleTauState, samples) -> MultipleTauState:
    """Add a chunk of samples, time along axis 0: ``lax.scan`` of :func:`update`.

    Args:
      state: correlator state.
      samples: ``(n_samples, *state.sample_shape)``.

    Returns:
      The state after all samples, in order.
    """
    samples = jnp.asarray(samples, state.buffer.dtype)
    if samples.shape[1:] != state.sample_shape:
        raise ValueError(
            f"samples must have shape (n_samples, *{state.sample_shape}), got {samples.shape}"
        )
    state, _ = jax.lax.scan(lambda s, x: (update(s, x), None), state, samples)
    return state


def lags(levels: int, points_per_level: int = 16, averaging: int = 2) -> np.ndarray:
    """Lags (in sample intervals) of :func:`result`, level by level, increasing.

    Level 0: ``0 .. p-1``; level ``l >= 1``: ``j m^l`` for ``j = p/m .. p-1``.
    Returns a NumPy int64 array of length ``p + (L - 1)(p - p/m)``.
    """
    level_index, distance_index = _selected_entries(levels, points_per_level, averaging)
    return (distance_index * averaging**level_index).astype(np.int64)


def _selected_entries(levels: int, points: int, averaging: int):
    """(level, distance) index arrays of the entries :func:`result` reports, in lag order."""
    level_index = [np.zeros(points, np.int64)]
    distance_index = [np.arange(points)]
    for level in range(1, levels):
        distance_index.append(np.arange(points // averaging, points))
        level_index.append(np.full(points - points // averaging, level))
    return np.concatenate(level_index), np.concatenate(distance_index)


@partial(jax.jit, static_argnames="averaging")
def _averages(correlation, counts, averaging: int):
    levels, points = counts.shape
    level_index, distance_index = _selected_entries(levels, points, averaging)
    sums = correlation[level_index, distance_index]
    n = _broadcast_mask(counts[level_index, distance_index], sums.ndim).astype(sums.dtype)
    return jnp.where(n > 0, sums / jnp.where(n > 0, n, 1), jnp.nan)


def result(state: MultipleTauState):
    """Lags and correlation estimates; jittable (fixed output shapes).

    Returns:
      ``(lags, correlation)``: NumPy int64 ``(K,)`` lags in sample intervals (see
      :func:`lags`) and an array ``(K, *sample_shape)`` of the averages
      ``sum / count``; NaN where no pair at that lag has been seen yet.
    """
    lag_values = lags(state.levels, state.points_per_level, state.averaging)
    return lag_values, _averages(state.correlation, state.counts, state.averaging)
