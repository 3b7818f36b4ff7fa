"""MPCD collision cells in the lattice coordinates of a Kraynik–Reinelt box.

A deforming periodic box can only be tiled by cells that deform with it: a
Cartesian grid of cubes does not fit the lattice F(ε) Λ0 at a general strain, so
cells at the faces would be cut (partly empty) or a particle would belong to two
cells through its images.  The grid is therefore that of the frame coordinates
(fractional coordinates in the current Gauss-reduced primary cell times the box
`lengths`, jaxdpd.geometry.boxes.kraynik_reinelt): n_0 × n_y × n_2 parallelepipeds,
each of volume V/(n_0 n_y n_2) = a³ at every strain, shifted at random in frame
coordinates before every collision (uniform over a cell in frame coordinates is
uniform over it in Cartesian ones: Galilean invariance as in jaxdpd.solvents.mpcd.cells).
This is the triclinic MPCD cell list of HOOMD-blue (cells counted along each lattice
vector; hoomd-blue issue 773, pull request 1813).  Why, and what the cell shape does
to the collisional stress: docs/solvent_flows/mpcd.md.

Velocities are stored peculiar (c = v − u(r)); a cell is a contiguous piece of the
periodic fluid, so its members are seen at the images that make it contiguous: their
laboratory velocities there are c_i + u(corner) + L ξ_i, ξ_i the Cartesian offset
from the cell's corner.  The collision rotates velocities relative to the cell mean,
so the common u(corner) drops out and c_i + L ξ_i is what the cell is given.
"""

import jax.numpy as jnp

from jaxdpd.solvents.mpcd.cells import CellBinning, cell_ids


def bin_in_lattice(grid, bound_box, positions, velocities, shift) -> CellBinning:
    """Sort particles into the shifted lattice cells of a Kraynik–Reinelt box.

    Args:
        grid: the collision grid of the frame lengths (L, L_y, L)
            (jaxdpd.solvents.mpcd.cells.CollisionGrid).
        bound_box: the Kraynik–Reinelt box at the collision (BoundKraynikReinelt).
        positions: (N, 3) positions wrapped into the primary cell.
        velocities: (N, 3) peculiar velocities.
        shift: (3,) grid shift in frame coordinates, in [0, a)³.
    Returns:
        CellBinning: `local` holds the Cartesian offsets ξ from each cell's corner
        (for the collisional virial), `frame_velocities` c + L ξ (module docstring).
    """
    dtype = positions.dtype
    lengths = jnp.asarray(grid.lengths, dtype)
    a = jnp.asarray(grid.cell_size, dtype)
    frame = bound_box.frame_positions(positions) - shift
    # Frame coordinates lie in [0, L) and s in [0, a): one periodic fold suffices.
    frame = jnp.where(frame < 0, frame + lengths, frame)
    index = jnp.floor(frame / a)
    offsets = frame - index * a
    local = jnp.stack(bound_box.frame_to_cartesian(tuple(offsets.T)), axis=1)
    frame_velocities = velocities + local @ bound_box.velocity_gradient.T
    return CellBinning(cell_ids(grid, index), local, frame_velocities)
