"""Which rows of a step's arrays belong to the stepping device, for sums over a system.

A step that runs on one device sums over its rows directly.  In a decomposed run
(jaxdpd.decomposition) a device steps the particles it owns together with copies of
its neighbours' particles near its faces (the halo) and free rows; a sum over the
whole system then counts the owned rows only and adds the domains' parts with a
collective.  The integrators take an `Ownership`, or None for a single device.

A step that works in rounds within one step (the Lowe–Andersen sweep) also needs
each row's particle identity and, between rounds, the copies brought up to date
with their owners (`resend`); `WHOLE_SYSTEM` is the Ownership of a single device,
where all of this is the identity.  The samplers of a decomposed run
(`Observable.domain_sampler`) take one too, with the rows' identities and `row_of`,
to find a bead's chain neighbour among the rows.
"""

from collections.abc import Callable
from dataclasses import dataclass

import jax.numpy as jnp


def _unchanged(x):
    return x


@dataclass(frozen=True)
class Ownership:
    """The stepping device's owned rows, the sum over all devices, and its copies.

    Attributes:
        owned: (R,) bool, the rows this device owns (traced); None: every row (one
            device).
        across_devices: `across_devices(x) -> x summed over the devices` (a psum
            over the mesh axis of the domains; x may be a pytree).
        identities: (R,) int32 particle identity of each row (−1: free row), or None
            where rows are identities.
        row_of: `row_of(identities) -> rows` holding those particles (present ones).
        resend: `resend(values) -> values` for a pytree of per-row arrays (R, ...):
            the rows of halo copies replaced by their owners' current values (one
            halo exchange); the owned rows unchanged.
    """

    owned: jnp.ndarray | None = None
    across_devices: Callable = _unchanged
    identities: jnp.ndarray | None = None
    row_of: Callable = _unchanged
    resend: Callable = _unchanged

    def weights(self, dtype):
        """(R,) 1 for an owned row, 0 for the others (a decomposed run's rows)."""
        return self.owned.astype(dtype)

    def share(self, per_row):
        """Σ over this device's owned rows of a per-row quantity (R, ...), in its
        dtype."""
        if self.owned is None:
            return jnp.sum(per_row, axis=0, dtype=per_row.dtype)
        mask = self.owned.reshape(self.owned.shape + (1,) * (per_row.ndim - 1))
        return jnp.sum(jnp.where(mask, per_row, 0), axis=0, dtype=per_row.dtype)

    def system_sum(self, per_row):
        """Σ over the system's particles of a per-row quantity (R, ...)."""
        return self.across_devices(self.share(per_row))

    def system_any(self, per_row):
        """Whether a per-row bool (R, ...) holds for any particle of the system (...)."""
        if self.owned is None:
            return jnp.any(per_row, axis=0)
        return self.system_sum(per_row.astype(jnp.int32)) > 0

    def identity_of(self, rows):
        """The particle identity held by each of `rows` (int array, valid rows)."""
        if self.identities is None:
            return rows
        return self.identities[rows]


# One device holding the whole system: every row owned, rows are identities.
WHOLE_SYSTEM = Ownership()
