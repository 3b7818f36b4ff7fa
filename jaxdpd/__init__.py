"""jaxdpd: differentiable, vectorised mesoscale simulation of polymer solutions.

Units are reduced DPD units (r_c = m = k_BT = 1) unless a scene says otherwise.

64-bit types are enabled on import so that a scene may ask for float64; every array
jaxdpd creates carries an explicit dtype, so float32 scenes stay float32.
"""

import jax

jax.config.update("jax_enable_x64", True)

__version__ = "0.1.0"
