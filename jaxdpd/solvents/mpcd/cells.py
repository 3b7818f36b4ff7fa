"""MPCD collision cells: a cubic grid of side a, shifted at random before every collision.

The grid tiles the box, every edge a whole number of cells.  Before each collision it
is shifted by a vector s drawn uniformly from [0, a)³, which restores the Galilean
invariance that a fixed grid breaks at small mean free paths (Ihle & Kroll, Phys.
Rev. E 63, 020201(R) (2001); Mussawisade et al. 2005, §II).  A particle at r then
belongs to the cell

    ξ = (r − s) mod L,   c = ⌊ξ / a⌋ (per axis),   id = c_x + n_x (c_y + n_y c_z),

and has the in-cell coordinates ξ − a c ∈ [0, a)³ (used by the collisional stress).
The shift is a pure function of (seed, collision index): `grid_shift`.

Lees–Edwards boxes (Kikuchi, Pooley, Ryder & Yeomans, J. Chem. Phys. 119, 6388
(2003)): the cell grid is that of the primary box; a cell that straddles the moving
boundary (y = 0 ≡ L_y) holds particles from below as their images above, displaced by
the offset Δ in x and moving faster by γ̇ L_y.  Velocities are stored peculiar
(c = v − u(r), SLLOD, jaxdpd.geometry.flows); the collision acts on the laboratory velocities
of the images (`CellBinning.frame_velocities`) and adds the change of velocity to the
stored ones.  `bin_particles` (and, for the Kraynik–Reinelt box, its lattice-cell
twin in jaxdpd.solvents.mpcd.lattice_cells) is the only place the box geometry enters
the collision.
"""

import math
from dataclasses import dataclass

import jax
import jax.numpy as jnp

from jaxdpd import pytree
from jaxdpd.engine import noise

# Bit streams of the per-collision random numbers (site 0 of the collision key); the
# cell and particle draws of jaxdpd.solvents.mpcd.collision use other streams.
SHIFT_STREAMS = (16, 17, 18)


@dataclass(frozen=True)
class CollisionGrid:
    """Cubic collision cells of side `cell_size` tiling a box of edges `lengths`.

    Attributes:
        lengths: box edges (L_x, L_y, L_z), each a whole multiple of cell_size.
        cell_size: a.
    """

    lengths: tuple[float, float, float]
    cell_size: float

    @property
    def shape(self) -> tuple[int, int, int]:
        """Cells per edge (n_x, n_y, n_z)."""
        return tuple(round(length / self.cell_size) for length in self.lengths)

    @property
    def n_cells(self) -> int:
        """Number of cells n_x n_y n_z."""
        return math.prod(self.shape)


def collision_grid(lengths, cell_size: float) -> CollisionGrid:
    """The grid of cells of side `cell_size` in a box of edges `lengths`.

    Raises:
        ValueError: an edge is not a whole multiple (within 10⁻⁹ relative) of the
            cell size, or holds fewer than 2 cells.
    """
    for axis, length in zip("xyz", lengths, strict=True):
        ratio = length / cell_size
        if abs(ratio - round(ratio)) > 1e-9 * ratio or round(ratio) < 2:
            raise ValueError(
                f"box.lengths: L_{axis} = {length:.6g} must be a whole multiple (≥ 2) of "
                f"solvent.cell_size = {cell_size:.6g} (L/a = {ratio:.6g}); adjust the box "
                "or the cell size"
            )
    return CollisionGrid(tuple(float(x) for x in lengths), float(cell_size))


def grid_shift(key, cell_size: float, dtype):
    """The random grid shift s of one collision, uniform in [0, a)³.

    Args:
        key: uint32 collision key (`noise.step_key(seed, collision index)`).
        cell_size: a.
        dtype: floating dtype.
    Returns:
        (3,) shift.
    """
    site = jnp.zeros((), jnp.uint32)
    return jnp.stack(
        [
            noise.bits_to_unit_interval(noise.site_bits(key, site, stream), dtype)
            for stream in SHIFT_STREAMS
        ]
    ) * jnp.asarray(cell_size, dtype)


@pytree.dataclass
class CellBinning:
    """Which cell each particle is in, for one collision (a pytree).

    Attributes:
        cell: (N,) uint32 cell id in [0, n_cells).
        local: (N, 3) in-cell coordinates in [0, a)³.
        frame_velocities: (N, 3) velocities of the particles as seen in the cell they
            were binned into (the stored velocities in a periodic box; with the
            velocity jump of their image in a Lees–Edwards box).
    """

    cell: jnp.ndarray
    local: jnp.ndarray
    frame_velocities: jnp.ndarray


def bin_particles(grid: CollisionGrid, bound_box, positions, velocities, shift) -> CellBinning:
    """Sort particles into the shifted cells (module docstring).

    Args:
        grid: the collision grid.
        bound_box: the box at the collision (jaxdpd.geometry.boxes, bound to its state): a box
            at rest, or a Lees–Edwards box (its offset Δ and streaming velocity).
        positions: (N, 3) positions wrapped into the box.
        velocities: (N, 3) velocities as stored (peculiar ones in a sheared box).
        shift: (3,) grid shift in [0, a)³.
    Returns:
        CellBinning with laboratory velocities in the cells' frame.
    """
    dtype = positions.dtype
    lengths = jnp.asarray(grid.lengths, dtype)
    a = jnp.asarray(grid.cell_size, dtype)
    shifted = positions - shift
    # r ∈ [0, L) and s ∈ [0, a) put r − s in (−a, L): one periodic fold suffices.
    below = shifted < 0
    shifted = jnp.where(below, shifted + lengths, shifted)
    frame_velocities = velocities
    if bound_box.velocity_gradient is not None:
        # Lees–Edwards (the flowing box whose boundary the cells cross): a particle
        # folded across y joins the cell as its image above, displaced by Δ in x and
        # moving with the streaming velocity there, u(y + L_y) = u(y) + γ̇ L_y.
        crossed = below[:, 1]
        x = shifted[:, 0] + jnp.where(crossed, bound_box.offset, 0)
        x = x - lengths[0] * jnp.floor(x / lengths[0])
        shifted = shifted.at[:, 0].set(x)
        image = positions.at[:, 1].add(jnp.where(crossed, lengths[1], 0))
        frame_velocities = velocities + bound_box.streaming_velocity(image)
    index = jnp.floor(shifted / a)
    local = shifted - index * a
    return CellBinning(cell_ids(grid, index), local, frame_velocities)


def cell_ids(grid: CollisionGrid, index):
    """Flat cell ids c_x + n_x (c_y + n_y c_z) from the cells along each axis.

    Args:
        grid: the collision grid.
        index: (N, 3) ⌊ξ/a⌋ as floats, in [0, n] along each axis: round-off can put a
            coordinate at exactly L (index n), which is folded into cell 0.
    Returns:
        (N,) uint32 ids in [0, n_cells).  An index outside [0, n] (not made by the
        binnings) still gives an id in range, but not its periodic image's.
    """
    shape = jnp.asarray(grid.shape, jnp.uint32)
    index = index.astype(jnp.uint32)
    index = jnp.where(index >= shape, index - shape, index)
    ids = index[:, 0] + shape[0] * (index[:, 1] + shape[1] * index[:, 2])
    # The remainder keeps every id in range whatever the input, so the collision's
    # gather may promise in-bounds indices.  It is also an operation XLA:CPU does not
    # duplicate into consumers: the ids are computed once, not again inside the
    # scatter and the gather (docs/performance_solvents.md).
    return ids % jnp.uint32(grid.n_cells)


def cell_totals(values, cell, n_cells: int):
    """Per-cell sums Σ_{i ∈ c} values_i (empty cells give 0).

    Args:
        values: (N, ...) per-particle values.
        cell: (N,) int cell ids.
        n_cells: number of cells.
    Returns:
        (n_cells, ...) sums.
    """
    return jax.ops.segment_sum(values, cell, n_cells)
