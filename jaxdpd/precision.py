"""JAX's 64-bit types, switched on where jaxdpd needs them, never at import.

JAX makes 32-bit arrays unless its process-wide option `jax_enable_x64` is set; with
it off, a float64 request is silently cut to float32.  jaxdpd needs 64-bit types for
every scene: a float64 scene for its state, and any scene for the uint64 words of the
cell-list neighbour search, the int64 sort keys and the float64 Lees–Edwards clock.
So `build` switches them on, as do the cell-list search, the Brownian-dynamics entry
points asked for float64 and the host-side estimators given float64 arrays.  Every
array jaxdpd creates carries an explicit dtype, so a float32 scene stays float32
with 64-bit types on.  Code that makes float64 JAX arrays itself before any of these
calls `jaxdpd.enable_float64()` first.
"""

import jax
import jax.numpy as jnp
import numpy as np

_DOUBLE = (np.dtype(np.float64), np.dtype(np.complex128))


def enable_float64() -> None:
    """Switch on JAX's 64-bit types (float64, int64, uint64) for this process.

    Raises:
        RuntimeError: when a surrounding `jax.enable_x64(False)` context keeps them
            off, so that float64 would silently become float32.
    """
    if jax.config.jax_enable_x64:
        return
    jax.config.update("jax_enable_x64", True)
    if not jax.config.jax_enable_x64:
        raise RuntimeError(
            "jaxdpd needs JAX's 64-bit types (jax_enable_x64), but a surrounding "
            "jax.enable_x64(False) context keeps them off; call jaxdpd outside it"
        )


def as_array(values):
    """`values` as a JAX array; a float64 (or complex128) NumPy array or scalar
    switches on 64-bit types first, so it keeps its precision instead of being cut
    to float32."""
    dtype = getattr(values, "dtype", None)
    if dtype is not None and np.dtype(dtype) in _DOUBLE:
        enable_float64()
    return jnp.asarray(values)
