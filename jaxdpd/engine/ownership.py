"""Which rows of a step's arrays belong to the stepping device, for sums over a system.

A step that runs on one device sums over its rows directly.  In a decomposed run
(jaxdpd.decomposition) a device steps the particles it owns together with copies of
its neighbours' particles near its faces (the halo) and free rows; a sum over the
whole system then counts the owned rows only and adds the domains' parts with a
collective.  The integrators take an `Ownership`, or None for a single device; the
samplers of a decomposed run (`Observable.domain_sampler`) take one too, with the
rows' particle identities, to find a bead's chain neighbour among the rows.
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
            over the mesh axis of the domains; x may be a pytree).
        identities: (R,) int32 particle identity of each row (−1: free row), or None
            where rows are identities.
        row_of: `row_of(identities) -> rows` holding those particles (present ones),
            or None where rows are identities.
    """

    owned: jnp.ndarray
    across_devices: Callable
    identities: jnp.ndarray | None = None
    row_of: Callable | None = None

    def weights(self, dtype):
        """(R,) 1 for an owned row, 0 for the others."""
        return self.owned.astype(dtype)

    def system_sum(self, per_row):
        """Σ over the system's particles of a per-row quantity (R, ...)."""
        mask = self.owned.reshape(self.owned.shape + (1,) * (per_row.ndim - 1))
        return self.across_devices(jnp.sum(jnp.where(mask, per_row, 0), axis=0))
