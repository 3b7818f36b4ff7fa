"""Orthorhombic periodic box (thesis §3.2).

Positions are stored wrapped into [0, L) per axis, with integer image counters so
that unwrapped coordinates r + n L can be recovered (thesis §3.2.4–3.2.5).

Every box type offers the same interface.  A box object is static (hashable; its
edge lengths fix array shapes at trace time); boxes that change with time (sheared,
elongated) keep a traced `box state` in `SimState.box_state` and are *bound* to it
inside a step (`box.bind(state.box_state)`), giving an object with the same methods
that reads the current offset or lattice.  A periodic box at rest has no state and
binds to itself, so no flow arithmetic is traced for it.  The unbound box's
`carry_images(image, before, after)` adjusts the counters when its state changes
(the Lees–Edwards offset wrap).

The interface (bound box):
    separation(components)       minimum-image (dx, dy, dz) of r_i − r_j
    minimum_image_vectors(v)     the same for vectors of shape (..., 3)
    spring_vectors(sep, dn)      spring vectors from raw separations and image-counter
                                 differences, and whether any is ambiguous
    wrap(positions, image)       positions back into the primary box, image counters
    unwrap(positions, image)     r + n · (lattice vectors) (periodic and Lees–Edwards)
    frame_positions(positions)   coordinates in which the lattice is rectangular with
                                 edges `lengths` (the cell list bins these)
    frame_to_cartesian(comps)    Cartesian separation from a frame separation
    velocity_gradient            (3, 3) L, u(r) = L (r − centre), or None at rest
"""

from dataclasses import dataclass
from typing import ClassVar

import jax.numpy as jnp


@dataclass(frozen=True)
class PeriodicBox:
    """A periodic box with edge lengths `lengths` = (L_x, L_y, L_z) in units of r_c.

    The lengths are static (Python floats): the cell grid of the neighbour search
    is derived from them at trace time.
    """

    lengths: tuple[float, float, float]

    name: ClassVar[str] = "periodic"
    flow_kind: ClassVar[str | None] = None  # the [flow] kind this box carries
    # Frame axes a decomposed run may cut into slabs (jaxdpd.decomposition.layout).
    slab_axes: ClassVar[tuple[int, ...]] = (0, 1, 2)

    @classmethod
    def from_scene(cls, lengths, flow=None) -> "PeriodicBox":
        """The box of a scene's box.lengths (a box at rest has no flow)."""
        return cls(lengths)

    # -- static description ----------------------------------------------------------
    @property
    def volume(self) -> float:
        """Box volume L_x L_y L_z."""
        lx, ly, lz = self.lengths
        return lx * ly * lz

    @property
    def cell_heights(self) -> tuple[float, float, float]:
        """The smallest distance between opposite faces of a frame cell row, per axis,
        over every shape the box takes (here the edges): cells of a neighbour grid
        must be at least the list cut-off thick in these units."""
        return self.lengths

    def lengths_array(self, dtype):
        """Edge lengths as a (3,) array of `dtype`."""
        return jnp.asarray(self.lengths, dtype)

    def initial_state(self, dtype):
        """The box state at time 0 (None: nothing changes)."""
        return None

    def advance(self, box_state, time, dt):
        """The box state after a step from `time` to `time + dt`."""
        return box_state

    def bind(self, box_state):
        """The box as it is in `box_state` (a box at rest is always itself)."""
        return self

    def carry_images(self, image, before, after):
        """Image counters after the box state went from `before` to `after` (a box at
        rest changes none)."""
        return image

    def image_drift(self, box_state, reference_state):
        """How far any periodic image has moved against the primary box since
        `reference_state` (never, at rest)."""
        return 0.0

    # -- geometry of a bound box -----------------------------------------------------
    velocity_gradient = None

    def minimum_image(self, separation, axis):
        """Minimum-image separation along one axis.

        Args:
            separation: array of separations along axis `axis` (any shape).
            axis: 0, 1 or 2.
        Returns:
            separation − L round(separation / L), in [−L/2, L/2].
        """
        length = jnp.asarray(self.lengths[axis], separation.dtype)
        return separation - length * jnp.round(separation / length)

    def separation(self, components):
        """Minimum-image (dx, dy, dz) from raw separations given as three arrays."""
        return tuple(self.minimum_image(c, axis) for axis, c in enumerate(components))

    def minimum_image_vectors(self, separations):
        """Minimum-image version of separation vectors of shape (..., 3)."""
        lengths = self.lengths_array(separations.dtype)
        return separations - lengths * jnp.round(separations / lengths)

    def spring_vectors(self, separation, image_difference):
        """Spring vectors r_{k+1} − r_k of unwrapped coordinates r + n L (thesis
        §3.2.4): exact at any length, so a spring may be longer than half the box
        (a chain of a few beads in a box of a few r_c).

        Args:
            separation: (..., 3) raw r_{k+1} − r_k of wrapped positions.
            image_difference: (..., 3) int image counters n_{k+1} − n_k.
        Returns:
            (springs (..., 3), ambiguous): never ambiguous here (False).
        """
        lengths = self.lengths_array(separation.dtype)
        springs = separation + image_difference.astype(separation.dtype) * lengths
        return springs, jnp.asarray(False)

    def wrap(self, positions, image):
        """Wrap positions into [0, L) and count the boundary crossings.

        Args:
            positions: (N, 3) positions, possibly outside the box.
            image: (N, 3) int32 image counters.
        Returns:
            (wrapped positions, updated image counters).
        """
        lengths = self.lengths_array(positions.dtype)
        crossings = jnp.floor(positions / lengths)
        wrapped, crossings = fold_edge(positions - crossings * lengths, crossings, lengths)
        return wrapped, image + crossings.astype(image.dtype)

    def unwrap(self, positions, image):
        """Unwrapped coordinates r + n L from wrapped positions and image counters."""
        return positions + image.astype(positions.dtype) * self.lengths_array(positions.dtype)

    def frame_positions(self, positions):
        """Cell-list coordinates: the wrapped positions themselves."""
        return positions

    def frame_to_cartesian(self, components):
        """A frame separation (dx, dy, dz) is already Cartesian."""
        return components


def fold_edge(wrapped, crossings, lengths):
    """Fold coordinates that round-off left outside [0, L) back in, and count the fold
    as a crossing: a tiny negative coordinate wraps to L in floating point, and a
    coordinate just below a multiple of L can round r/L up to an integer, leaving a
    tiny negative remainder.

    Returns:
        (wrapped in [0, L), crossings).
    """
    below = wrapped < 0
    wrapped = jnp.where(below, wrapped + lengths, wrapped)
    above = wrapped >= lengths
    return jnp.where(above, wrapped - lengths, wrapped), crossings - below + above
