"""Input checks shared by the Brownian-dynamics modules (run before tracing).

Values that are JAX tracers (inside ``jit``/``grad``/``vmap``) cannot be inspected and
are let through: the public entry points check their inputs while they are still
concrete, so a bad value is refused before anything is traced.
"""

from __future__ import annotations

import jax
import jax.numpy as jnp
import numpy as np

from jaxdpd.precision import enable_float64

FLOAT_DTYPES = (jnp.float32, jnp.float64)


def float_dtype(dtype, name: str = "dtype"):
    """Return ``dtype`` as a NumPy dtype, refusing anything but float32/float64; a
    float64 request switches on JAX's 64-bit types (jaxdpd.precision)."""
    try:
        dt = np.dtype(dtype)
    except TypeError as err:
        raise ValueError(f"{name} must be float32 or float64, got {dtype!r}") from err
    if dt not in (np.dtype(np.float32), np.dtype(np.float64)):
        raise ValueError(f"{name} must be float32 or float64, got {dt}")
    if dt == np.dtype(np.float64):
        enable_float64()
    return dt


def concrete(value):
    """``value`` as a float64 NumPy array, or None when it is a tracer/not numeric."""
    if isinstance(value, jax.core.Tracer):
        return None
    try:
        return np.asarray(value, dtype=np.float64)
    except (TypeError, ValueError):
        return None


def check_positive(name: str, value, *, allow_zero: bool = False, allow_inf: bool = False):
    """Raise ValueError unless every concrete entry of ``value`` is > 0 (or >= 0)."""
    arr = concrete(value)
    if arr is None:
        return
    bad = ~np.isfinite(arr) if not allow_inf else np.isnan(arr)
    bad |= (arr < 0) if allow_zero else (arr <= 0)
    if np.any(bad):
        rng = "[0, inf)" if allow_zero else "(0, inf)"
        shown = arr if arr.ndim == 0 else arr[bad]
        raise ValueError(f"{name} must be finite and in {rng}, got {shown}")


def check_count(name: str, value, minimum: int = 1) -> int:
    """Raise ValueError unless ``value`` is a Python/NumPy integer >= ``minimum``."""
    if isinstance(value, bool) or not isinstance(value, int | np.integer):
        raise ValueError(f"{name} must be an integer >= {minimum}, got {value!r}")
    if value < minimum:
        raise ValueError(f"{name} must be an integer >= {minimum}, got {value}")
    return int(value)
