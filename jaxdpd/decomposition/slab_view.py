"""A device's view of the box for the cell list: its slab and halos, cut out of the box.

The particles a device steps keep their coordinates in the whole box (wrapped
there, separated by its minimum image, streamed by its flow).  Only the neighbour
search needs to see less than the whole box: `SlabView` is a box for the cell list
(jaxdpd.geometry.neighbors.cell_list) whose frame has the extent of the device's
slab, halos and gap along the cut axis (`SlabLayout.local_length`) and the box's own
extent along the others.  Its frame coordinate along the cut axis is the box's,
measured from the view's lower end (`SlabState.origin`) and wrapped into the view,
so the grid and its dense tests cover the device's part only, and the gap keeps the
two halos apart across the view's periodic end.
"""

from dataclasses import dataclass

import jax.numpy as jnp

from jaxdpd import pytree


@pytree.dataclass
class SlabState:
    """The box state and where the view begins.

    Attributes:
        box_state: the whole box's state (None at rest).
        origin: frame coordinate, along the cut axis, of the view's lower end.
    """

    box_state: object
    origin: jnp.ndarray


def _replaced(values, axis: int, value):
    return tuple(value if a == axis else v for a, v in enumerate(values))


@dataclass(frozen=True)
class SlabView:
    """The box seen by one device (see the module docstring).

    Args:
        box: the whole box (static).
        axis: the cut frame axis.
        length: the view's extent along it.
    """

    box: object
    axis: int
    length: float

    @property
    def lengths(self) -> tuple[float, float, float]:
        return _replaced(self.box.lengths, self.axis, self.length)

    @property
    def cell_heights(self) -> tuple[float, float, float]:
        return _replaced(self.box.cell_heights, self.axis, self.length)

    @property
    def volume(self) -> float:
        return self.box.volume * self.length / self.box.lengths[self.axis]

    def bind(self, state: SlabState) -> "BoundSlabView":
        return BoundSlabView(self.box.bind(state.box_state), self.axis, self.lengths, state.origin)


@dataclass(frozen=True)
class BoundSlabView:
    """A SlabView at one instant: frame coordinates and frame → Cartesian map."""

    bound: object
    axis: int
    lengths: tuple[float, float, float]
    origin: jnp.ndarray

    def frame_positions(self, positions):
        """The box's frame coordinates, the cut one measured from the view's origin
        and wrapped into the whole box's period along it."""
        frame = self.bound.frame_positions(positions)
        period = jnp.asarray(self.bound.lengths[self.axis], frame.dtype)
        along = frame[:, self.axis] - self.origin.astype(frame.dtype)
        along = along - period * jnp.floor(along / period)
        return frame.at[:, self.axis].set(along)

    def frame_to_cartesian(self, components):
        return self.bound.frame_to_cartesian(components)
