"""Wiener increments of the Brownian dumbbells, counter-based.

The increments of dumbbell i at step n are a pure function of (PRNG key, n, i,
component): the 32-bit words ``site_bits(noise_key(key, n), i, stream)`` of
jaxdpd.engine.noise (the hash of the DPD pair noise), as the project's randomness
policy asks.  A trajectory does not depend on how steps are chunked or dumbbells
batched, and a vmap over keys runs independent ensembles.  Everything is elementwise
arithmetic that XLA vectorises on the CPU: no scalar library calls (float64 logarithm,
cosine) and no ``jax.random`` key splitting per step.
"""

import math

import jax
import jax.numpy as jnp

from jaxdpd.engine import noise as _noise
from jaxdpd.trigonometry import sincos_small

__all__ = ["NOISES", "check_noise", "noise_key", "wiener_increments"]

_SALT = 0xB7D5E1A3  # the Brownian increments' family of counter-based streams

NOISES = ("gaussian", "three_point")


def check_noise(noise) -> str:
    """Return ``noise`` if it names a known increment distribution, else ValueError."""
    if not isinstance(noise, str) or noise not in NOISES:
        raise ValueError(f"noise must be one of {NOISES}, got {noise!r}")
    return noise


def noise_key(key, step):
    """uint32 key of one step's increments: a hash of the PRNG key's words and ``step``.

    ``key`` is a JAX PRNG key (typed, or the legacy uint32 array); different keys give
    independent streams, so a vmap over keys runs independent ensembles.
    """
    if jnp.issubdtype(key.dtype, jax.dtypes.prng_key):
        key = jax.random.key_data(key)
    words = jnp.ravel(key).astype(jnp.uint32)
    seed = _noise.mix32(words[0] ^ jnp.uint32(_SALT))
    for index in range(1, words.shape[0]):
        seed = _noise.mix32(seed ^ _noise.mix32(words[index] + jnp.uint32(index)))
    return _noise.step_key(seed, step)


def _unit(bits, dtype):
    """Uniform variate on (0, 1) from 32 bits: all 32 in float64, the top 24 (exact)
    in float32; never 0 or 1 (safe for the logarithm)."""
    if jnp.dtype(dtype).itemsize == 8:
        return (bits.astype(dtype) + 0.5) * 2.0**-32
    return _noise.bits_to_unit_interval(bits, dtype)


_ATANH_TERMS = tuple(1 / (2 * k + 1) for k in range(11))


def _log_unit(u):
    """ln u for u in (0, 1), in float64 by frexp and the series
    ln m = 2 atanh s = 2 s (1 + s^2/3 + ... + s^20/21), s = (m - 1)/(m + 1), with m in
    [1/sqrt 2, sqrt 2) (|s| < 0.172: truncation below 1e-17); float32 uses XLA's log.

    XLA's CPU float64 logarithm is a scalar library call that keeps the fusion around
    it from vectorising; this is arithmetic only.
    """
    if jnp.dtype(u.dtype).itemsize != 8:
        return jnp.log(u)
    mantissa, exponent = jnp.frexp(u)
    low = mantissa < 1 / math.sqrt(2)
    mantissa = jnp.where(low, 2 * mantissa, mantissa)
    exponent = jnp.where(low, exponent - 1, exponent).astype(u.dtype)
    s = (mantissa - 1) / (mantissa + 1)
    s2 = s * s
    series = 0
    for term in reversed(_ATANH_TERMS):
        series = series * s2 + term
    return exponent * math.log(2) + 2 * s * series


def _circle_point(bits, dtype):
    """``(cos theta, sin theta)`` of a uniform angle, from 32 bits.

    The top 30 bits give ``phi`` uniform on ``(-pi/4, pi/4)`` (Taylor series to
    ``phi^15``, jaxdpd.trigonometry.sincos_small): the point ``(cos phi, sin phi)``
    of the right quarter of the circle.  Bit 1 flips the sign of the cosine (right or
    left quarter) and bit 0 swaps the coordinates (top or bottom quarter): each
    quarter with probability 1/4, so the angle is uniform.  No range reduction.
    """
    fraction = ((bits >> 2).astype(dtype) + 0.5) * 2.0**-30 - 0.5
    sine, cosine = sincos_small(fraction * (jnp.pi / 2))
    cosine = jnp.where((bits & 2) == 2, -cosine, cosine)
    swap = (bits & 1) == 1
    return jnp.where(swap, sine, cosine), jnp.where(swap, cosine, sine)


def wiener_increments(key, step, n, dt, dtype, noise="gaussian"):
    """``(n, 3)`` increments ``dW`` for step ``step``; counter-based in (key, step,
    dumbbell, component).

    Every variate is a function of the bits ``site_bits(noise_key(key, step), i, s)``
    of dumbbell ``i`` and stream ``s`` (jaxdpd.engine.noise, the hash of the DPD pair
    noise): nothing depends on how steps are chunked or dumbbells batched.

    ``gaussian``: ``sqrt(dt) N(0, I)`` (exact Wiener increments) by Box–Muller from
    four streams: radii ``sqrt(-2 ln u)`` from streams 0 and 2, angles from streams 1
    and 3 (:func:`_circle_point`); components ``r0 cos, r0 sin, r2 cos``.

    ``three_point``: each component is ``sqrt(3 dt) * {-1, 0, +1}`` with probabilities
    ``{1/6, 2/3, 1/6}``.  Its moments up to fifth order equal those of ``N(0, dt)``,
    which is what weak order two requires (Kloeden & Platen, *Numerical Solution of
    SDEs* (1992), ch. 14), so stationary averages converge as
    with Gaussian noise; it has no density (no likelihood-ratio estimator).  The three
    components come from the base-6 digits of one 32-bit word (stream 0): each
    probability is exact up to a relative bias below ``216 / 2^32 = 5e-8``.
    """
    if n * 4 >= 2**32:
        raise ValueError(f"wiener_increments: n = {n} dumbbells exceed the 2^30 counters")
    k = noise_key(key, step)
    dumbbells = jnp.arange(n, dtype=jnp.uint32)
    if noise == "gaussian":
        words = [_noise.site_bits(k, dumbbells, stream) for stream in range(4)]
        r0, r2 = (jnp.sqrt(-2 * _log_unit(_unit(words[s], dtype))) for s in (0, 2))
        (c0, s0), (c2, _) = (_circle_point(words[s], dtype) for s in (1, 3))
        return jnp.sqrt(dt) * jnp.stack([r0 * c0, r0 * s0, r2 * c2], axis=-1)
    bits = _noise.site_bits(k, dumbbells, 0)
    six = jnp.uint32(6)
    digits = jnp.stack([bits % six, (bits // six) % six, (bits // jnp.uint32(36)) % six], -1)
    sign = (digits == 5).astype(dtype) - (digits == 0).astype(dtype)
    return jnp.sqrt(3 * dt) * sign
