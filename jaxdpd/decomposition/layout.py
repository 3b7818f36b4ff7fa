"""The slabs of a decomposed box: which device owns which part, and how thick its halo is.

The box is cut normal to one frame axis into D slabs of equal width w = L/D, one per
device.  A device owns the particles whose frame coordinate along that axis lies in
its slab, and before each step receives copies of its two neighbours' particles
within the halo width h of its faces.  Only the neighbours' slabs can hold them, so
every slab must be at least h thick (2h with two devices, whose one neighbour sits on
both faces).  The frame axes a box can be cut along are its `slab_axes`: any axis of
a box at rest; y (the gradient) or z of a Lees–Edwards box, whose sheared frame
coordinate u = x − (Δ/L_y) y is the same for a particle and its image across the
moving boundary; y, the neutral axis, of a Kraynik–Reinelt box, whose x–z lattice
deforms.
"""

import math
from dataclasses import dataclass

import jax.numpy as jnp

AXES = "xyz"


@dataclass(frozen=True)
class SlabLayout:
    """Slabs along one frame axis and the buffers each device holds.

    Attributes:
        axis: frame axis normal to the slabs (0, 1, 2).
        domains: number of slabs D (one per device).
        box_length: the box's frame length L along the axis.
        halo: halo width h: the interaction reach plus the margin particles may move
            within one step.
        capacity: rows per device for the particles it owns.
        halo_capacity: rows per face for the copies a neighbour sends.
        migration_capacity: rows per face for the particles that change slab in
            one step.
    """

    axis: int
    domains: int
    box_length: float
    halo: float
    capacity: int
    halo_capacity: int
    migration_capacity: int

    @property
    def width(self) -> float:
        """Slab width w = L/D."""
        return self.box_length / self.domains

    def view_origin(self, device, dtype):
        """Frame coordinate where a device's view begins: its slab's lower face − h."""
        return device.astype(dtype) * jnp.asarray(self.width, dtype) - jnp.asarray(self.halo, dtype)

    def view_coordinate(self, along, device):
        """Frame coordinates along the axis measured from the device's view origin,
        wrapped into one box period (owned particles: [h, h + w))."""
        relative = along - self.view_origin(device, along.dtype)
        period = jnp.asarray(self.box_length, along.dtype)
        return relative - period * jnp.floor(relative / period)

    def owner(self, along):
        """The device whose slab holds each frame coordinate along the axis."""
        slab = jnp.floor(along / jnp.asarray(self.width, along.dtype)).astype(jnp.int32)
        return jnp.clip(slab, 0, self.domains - 1)

    @property
    def local_length(self) -> float:
        """Extent along the axis of what a device sees: its slab, a halo on each
        face and an empty gap of one halo width, so that the two halos never meet
        across the periodic boundary of the device's cell grid."""
        return self.width + 3 * self.halo


def slab_axis(box, axis_name: str | None) -> int:
    """The frame axis to cut: `parallel.axis` if given, else the box's first
    slab axis with the longest edge."""
    allowed = box.slab_axes
    if axis_name is not None:
        axis = AXES.index(axis_name)
        if axis not in allowed:
            raise ValueError(
                f"parallel.axis = {axis_name!r}: a {box.name} box is cut along "
                f"{[AXES[a] for a in allowed]} only (jaxdpd.decomposition.layout)"
            )
        return axis
    return max(allowed, key=lambda a: (box.lengths[a], -a))


def slab_room(devices: int, halo: float) -> float:
    """The thinnest slab `devices` slabs may have: one halo, two with two devices."""
    return halo * (2 if devices == 2 else 1)


def most_devices(box_length: float, halo: float) -> int:
    """The largest number of slabs a box edge allows (1: none)."""
    for devices in range(math.floor(box_length / halo), 1, -1):
        if box_length / devices >= slab_room(devices, halo):
            return devices
    return 1


def check_slabs(devices: int, axis: int, box_length: float, halo: float):
    """Refuse slabs thinner than `slab_room`, naming what would fit."""
    width = box_length / devices
    if width < slab_room(devices, halo):
        raise ValueError(
            f"parallel.devices = {devices}: slabs of the {AXES[axis]} edge {box_length:.4g} "
            f"would be {width:.4g} thick, thinner than {slab_room(devices, halo):.4g} (the "
            f"halo {halo:.4g}: the longest reach, pair cut-off or FENE bond, plus "
            "parallel.margin"
            f"{'; twice that with two devices' if devices == 2 else ''}); use at most "
            f"{most_devices(box_length, halo)} devices along {AXES[axis]}, a longer box, "
            "or a smaller parallel.margin"
        )


def head_room(count: float) -> float:
    """Rows for a particle count that fluctuates about `count`: four Poisson spreads
    √count above it, and 8 more for small counts (a liquid, less compressible than
    an ideal gas, fluctuates less)."""
    return count + 4 * math.sqrt(count) + 8


def buffer_sizes(n_particles: int, devices: int, width: float, halo: float, multiplier: float):
    """(capacity, halo_capacity, migration_capacity) for a uniform fluid, with head room.

    A slab holds N/D particles on average, a halo layer N/D · h/w of them;
    `head_room` times the multiplier covers a random start's fluctuations (a run
    that needs more reallocates).
    """
    per_slab = n_particles / devices
    per_halo = per_slab * min(1.0, halo / width)
    return tuple(
        math.ceil(multiplier * head_room(mean)) for mean in (per_slab, per_halo, 0.25 * per_halo)
    )
