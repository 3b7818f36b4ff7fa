"""Particles between neighbouring devices: halo copies and migration, by `ppermute`.

Every array here is one device's, inside `jax.shard_map` over the mesh axis
`DOMAINS`; device k's neighbours along the cut axis are k − 1 and k + 1 (mod D).
A particle travels as a `Rows` record (identity, position, velocity, force, image
counters, species).  Buffers have fixed sizes (XLA needs static shapes); a free row
has identity −1 and zeros elsewhere (finite, so that no sum over rows turns NaN).
Each send reports how many rows it needed, so that an overflow can be reported and
the buffers enlarged.
"""

from dataclasses import dataclass

import jax
import jax.numpy as jnp

from jaxdpd import pytree
from jaxdpd.scatter import nonzero_indices

DOMAINS = "domains"  # the mesh axis of the slabs


@pytree.dataclass
class Rows:
    """Particle rows of one device (R rows; free rows have ids −1).

    Attributes:
        ids: (R,) int32 particle identity (its index in the scene), −1 when free.
        positions, velocities, forces: (R, 3), zeros in free rows.
        image: (R, 3) int32 image counters.
        species: (R,) int32 species index.
    """

    ids: jnp.ndarray
    positions: jnp.ndarray
    velocities: jnp.ndarray
    forces: jnp.ndarray
    image: jnp.ndarray
    species: jnp.ndarray

    @property
    def present(self):
        """(R,) bool, rows that hold a particle."""
        return self.ids >= 0


def free_rows(count: int, dtype) -> Rows:
    """`count` free rows."""
    vectors = jnp.zeros((count, 3), dtype)
    return Rows(
        ids=jnp.full(count, -1, jnp.int32),
        positions=vectors,
        velocities=vectors,
        forces=vectors,
        image=jnp.zeros((count, 3), jnp.int32),
        species=jnp.zeros(count, jnp.int32),
    )


def concatenate(*parts: Rows) -> Rows:
    """The rows of `parts`, one after the other."""
    return jax.tree.map(lambda *leaves: jnp.concatenate(leaves), *parts)


def take(rows: Rows, index) -> Rows:
    """Rows at `index` (an index equal to the row count gives a free row)."""
    padded = concatenate(rows, free_rows(1, rows.positions.dtype))
    return jax.tree.map(lambda leaf: leaf[index], padded)


def release(rows: Rows, leaving) -> Rows:
    """`rows` with the rows where `leaving` is True made free."""
    free = free_rows(rows.ids.shape[0], rows.positions.dtype)

    def pick(kept, emptied):
        mask = leaving.reshape(leaving.shape + (1,) * (kept.ndim - 1))
        return jnp.where(mask, emptied, kept)

    return jax.tree.map(pick, rows, free)


def select(rows: Rows, mask, capacity: int):
    """The rows where `mask` holds, packed into `capacity` rows (free rows after).

    Returns:
        (Rows of `capacity` rows, int32 number of rows selected, which may exceed
        the capacity: the surplus is dropped and must be reported).
    """
    index, count = pick(mask, capacity)
    return take(rows, index), count


def pick(mask, capacity: int):
    """(the first `capacity` row indices where `mask` holds, padded with the row
    count; int32 number of rows where it holds)."""
    count = jnp.sum(mask, dtype=jnp.int32)
    return nonzero_indices(mask, capacity, mask.shape[0]), count


def shift(rows, towards: int, domains: int):
    """Send every device's `rows` (any pytree of arrays) to its neighbour
    k + towards (towards = ±1) and receive those of neighbour k − towards."""
    permutation = [(k, (k + towards) % domains) for k in range(domains)]
    return jax.lax.ppermute(rows, DOMAINS, permutation)


def admit(rows: Rows, arrivals: Rows):
    """Place the particles of `arrivals` into free rows of `rows`.

    Returns:
        (rows, int32 number of arrivals that found no free row).
    """
    arriving = arrivals.present
    free = ~rows.present
    capacity = rows.ids.shape[0]
    count = jnp.sum(arriving, dtype=jnp.int32)
    packed, _ = select(arrivals, arriving, arrivals.ids.shape[0])
    slots = nonzero_indices(free, arrivals.ids.shape[0], capacity)
    # The k-th arrival goes to the k-th free row; free arrival rows land in free
    # rows (no change) or, past the free rows, nowhere.
    admitted = jax.tree.map(lambda kept, new: kept.at[slots].set(new, mode="drop"), rows, packed)
    return admitted, jnp.maximum(count - jnp.sum(free, dtype=jnp.int32), 0)


@dataclass(frozen=True)
class HaloRoute:
    """Which owned rows a device sent as halo copies, to repeat the exchange later.

    Attributes:
        down, up: (H,) the rows sent to neighbour k − 1 and k + 1 (R: none).
        devices: D.
    """

    down: jnp.ndarray
    up: jnp.ndarray
    devices: int

    def resend(self, values):
        """`values` (a pytree of per-row arrays, owned rows then the copies from below
        and from above, as `with_halos` lays them out) with every copy replaced by
        its owner's current value: the same halo exchange, for these values only."""
        copies = 2 * self.up.shape[0]

        def sent(index):
            # Row R (past the owned rows) is a free row: zeros.
            return jax.tree.map(
                lambda leaf: jnp.take(leaf[: leaf.shape[0] - copies], index, axis=0, fill_value=0),
                values,
            )

        from_below = shift(sent(self.up), 1, self.devices)
        from_above = shift(sent(self.down), -1, self.devices)
        return jax.tree.map(
            lambda leaf, below, above: jnp.concatenate(
                [leaf[: leaf.shape[0] - copies], below, above]
            ),
            values,
            from_below,
            from_above,
        )


def with_halos(rows: Rows, along, width: float, halo: float, capacity: int, devices: int):
    """The device's rows followed by copies of its neighbours' rows near its faces.

    Args:
        rows: the rows the device owns.
        along: (R,) their frame coordinate along the cut axis, measured from the
            device's view origin (`SlabLayout.view_coordinate`): owned rows lie in
            [h, h + w).
        width, halo: slab width w and halo width h.
        capacity: rows per face for the copies.
    Returns:
        (rows + copies from below + copies from above (R + 2 capacity rows), int32
        copies the busier face had to send: more than `capacity` were cut off, the
        `HaloRoute` of the copies sent).
    """
    down_index, sent_down = pick(rows.present & (along < 2 * halo), capacity)
    up_index, sent_up = pick(rows.present & (along >= width), capacity)
    down, up = take(rows, down_index), take(rows, up_index)
    local = concatenate(rows, shift(up, 1, devices), shift(down, -1, devices))
    return local, jnp.maximum(sent_down, sent_up), HaloRoute(down_index, up_index, devices)


def hand_over(rows: Rows, owner, device, devices: int, capacity: int):
    """Send each particle whose slab is now another device's to that neighbour, and
    take in the particles the neighbours send.

    Args:
        rows: the device's rows after a step.
        owner: (R,) int32 device of each row's slab now (`SlabLayout.owner`).
        device: this device's index.
        capacity: rows per face for the migrants.
    Returns:
        (rows, int32 migrants over the busier face, int32 arrivals that found no
        free row, bool: a particle moved past the neighbouring slab).
    """
    leaving = rows.present & (owner != device)
    hops = (owner - device) % devices
    upward = leaving & (hops == 1)
    downward = leaving & (hops != 1)
    ups, left_up = select(rows, upward, capacity)
    downs, left_down = select(rows, downward, capacity)
    arrivals = concatenate(shift(ups, 1, devices), shift(downs, -1, devices))
    kept, homeless = admit(release(rows, leaving), arrivals)
    skipped = jnp.any(downward & (hops != devices - 1))
    return kept, jnp.maximum(left_up, left_down), homeless, skipped
