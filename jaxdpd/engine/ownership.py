"""Which rows of a step's arrays belong to the stepping device, for sums over a system.

A step that runs on one device sums over its rows directly.  In a decomposed run
(jaxdpd.decomposition) a device steps the particles it owns together with copies of
its neighbours' particles near its faces (the halo) and free rows; a sum over the
whole system then counts the owned rows only and adds the domains' parts with a
collective.  The integrators take an `Ownership`, or None for a single device.
"""

from collections.abc import Callable
from dataclasses import dataclass

import jax.numpy as jnp


@dataclass(frozen=True)
class Ownership:
    """The stepping device's owned rows and the sum over all devices.

    Attributes:
        owned: (R,) bool, the rows this device owns (traced).
        across_devices: `across_devices(x) -> x summed over the devices` (a psum
            over the mesh axis of the domains).
    """

    owned: jnp.ndarray
    across_devices: Callable

    def weights(self, dtype):
        """(R,) 1 for an owned row, 0 for the others."""
        return self.owned.astype(dtype)

    def system_sum(self, per_row):
        """Σ over the system's particles of a per-row quantity (R, ...)."""
        mask = self.owned.reshape(self.owned.shape + (1,) * (per_row.ndim - 1))
        return self.across_devices(jnp.sum(jnp.where(mask, per_row, 0), axis=0))
