"""Which rows of a step's arrays belong to the stepping device, for sums over a system.

A step that runs on one device sums over its rows directly.  In a decomposed run
(jaxdpd.decomposition) a device steps the particles it owns together with copies of
its neighbours' particles near its faces (the halo) and free rows; a sum over the
whole system then counts the owned rows only and adds the domains' parts with a
collective.  The integrators take an `Ownership`, or None for a single device; the
samplers of a decomposed run (`Observable.domain_sampler`) take one too, with the
particle identity of every row, to find a bead's chain by identity.
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
        ids: (R,) int32 particle identity (scene index) of each row, −1 for a free
            row, or None where the rows are not given identities.
    """

    owned: jnp.ndarray
    across_devices: Callable
    ids: jnp.ndarray | None = None

    def weights(self, dtype):
        """(R,) 1 for an owned row, 0 for the others."""
        return self.owned.astype(dtype)

    def system_sum(self, per_row):
        """Σ over the system's particles of a per-row quantity (R, ...)."""
        mask = self.owned.reshape(self.owned.shape + (1,) * (per_row.ndim - 1))
        return self.across_devices(jnp.sum(jnp.where(mask, per_row, 0), axis=0))


def identity_lookup(ids):
    """`row_of(wanted) -> (row, present)`: the row holding each identity of `wanted`
    (any row where absent) and whether it is there; the rows are sorted by identity
    once."""
    absent = jnp.iinfo(jnp.int32).max
    order = jnp.argsort(jnp.where(ids >= 0, ids, absent))
    ordered = ids[order]

    def row_of(wanted):
        place = jnp.minimum(jnp.searchsorted(ordered, wanted), ids.shape[0] - 1)
        return order[place], ordered[place] == wanted

    return row_of
