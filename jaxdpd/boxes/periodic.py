"""Orthorhombic periodic box (thesis §3.2).

Positions are stored wrapped into [0, L) per axis, with integer image counters so
that unwrapped coordinates r + n L can be recovered (thesis §3.2.4–3.2.5).
"""

from dataclasses import dataclass

import jax.numpy as jnp
from jax_md import space


@dataclass(frozen=True)
class PeriodicBox:
    """A periodic box with edge lengths `lengths` = (L_x, L_y, L_z) in units of r_c.

    The lengths are static (Python floats): the cell grid of the neighbour search
    is derived from them at trace time.
    """

    lengths: tuple[float, float, float]

    @property
    def volume(self) -> float:
        """Box volume L_x L_y L_z."""
        lx, ly, lz = self.lengths
        return lx * ly * lz

    def lengths_array(self, dtype):
        """Edge lengths as a (3,) array of `dtype`."""
        return jnp.asarray(self.lengths, dtype)

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

    def minimum_image_vectors(self, separations):
        """Minimum-image version of separation vectors of shape (..., 3)."""
        lengths = self.lengths_array(separations.dtype)
        return separations - lengths * jnp.round(separations / lengths)

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
        wrapped = positions - crossings * lengths
        # Round-off can leave a coordinate just below 0 (r/L rounded up to an integer)
        # or at L (−tiny + L rounds to L): fold it into [0, L) and count the fold in
        # the image, so that r + image · L stays the unwrapped position.
        below = wrapped < 0
        wrapped = jnp.where(below, wrapped + lengths, wrapped)
        above = wrapped >= lengths
        wrapped = jnp.where(above, wrapped - lengths, wrapped)
        crossings = crossings - below + above
        return wrapped, image + crossings.astype(image.dtype)

    def unwrap(self, positions, image):
        """Unwrapped coordinates r + n L from wrapped positions and image counters."""
        return positions + image.astype(positions.dtype) * self.lengths_array(positions.dtype)

    def jax_md_space(self):
        """jax-md's (displacement_fn, shift_fn) for this box (wrapped coordinates)."""
        return space.periodic(jnp.asarray(self.lengths, jnp.float64))
