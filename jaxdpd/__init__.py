"""jaxdpd: differentiable, vectorised mesoscale simulation of polymer solutions.

Units are reduced DPD units (r_c = m = k_BT = 1) unless a scene says otherwise.

Importing jaxdpd leaves JAX's configuration alone.  Building a scene switches on
JAX's 64-bit types, which the engine needs (see jaxdpd.precision); call
`enable_float64()` first to make float64 JAX arrays of your own.
"""

from jaxdpd.precision import enable_float64

__all__ = ["enable_float64"]

__version__ = "0.1.0"
