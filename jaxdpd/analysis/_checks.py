"""Input checks shared by the polymer estimators and observables (run before tracing).

Shapes and dtypes are static under ``jit``, so these checks also work on tracers.
"""

from __future__ import annotations

import jax.numpy as jnp

from jaxdpd.precision import as_array


def floating_array(values, name: str, min_ndim: int = 1):
    """``values`` as a JAX array of float32/float64 with at least ``min_ndim`` axes;
    float64 input keeps float64 (jaxdpd.precision.as_array)."""
    array = as_array(values)
    if not jnp.issubdtype(array.dtype, jnp.floating):
        raise ValueError(
            f"{name} must hold float32 or float64 values, got dtype {array.dtype}; "
            "convert explicitly (e.g. x.astype(jnp.float64))"
        )
    if array.ndim < min_ndim:
        raise ValueError(f"{name} must have at least {min_ndim} axes, got shape {array.shape}")
    return array


def chain_positions(chains, name: str = "chains", min_beads: int = 2):
    """Unwrapped chain positions ``(..., n_chains, n_beads, 3)`` as a floating array."""
    array = floating_array(chains, name, min_ndim=3)
    if array.shape[-1] != 3:
        raise ValueError(
            f"{name} must have shape (..., n_chains, n_beads, 3), got {array.shape} "
            "(last axis is not 3)"
        )
    if array.shape[-2] < min_beads:
        raise ValueError(
            f"{name} must have at least {min_beads} beads per chain, got shape {array.shape}"
        )
    return array


def positive_int(value, name: str, minimum: int = 1) -> int:
    """``value`` as a Python int >= ``minimum``, refusing bools and non-integers."""
    if isinstance(value, bool) or not hasattr(value, "__index__"):
        raise ValueError(f"{name} must be an integer >= {minimum}, got {value!r}")
    value = int(value)
    if value < minimum:
        raise ValueError(f"{name} must be an integer >= {minimum}, got {value}")
    return value
