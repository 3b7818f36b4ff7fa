"""jaxdpd's boxes, cell list and SLLOD streaming as jax-md building blocks.

- `space(box)`: `(displacement_fn, shift_fn)` for every box of `BOXES` (periodic,
  Lees–Edwards, Kraynik–Reinelt), with the box state passed per call as `box=`;
- `neighbor_list(box, r_cutoff, dr_threshold, ...)`: a `jax_md.partition.NeighborListFns`
  backed by jaxdpd's cell list, valid in all three boxes;
- `sllod(energy_or_force_fn, box, dt, ...)`: an `(init_fn, apply_fn)` integrator for
  homogeneous shear and planar elongation with the box clock in its state.

The reverse direction (jax-md's list inside jaxdpd) is
jaxdpd.geometry.neighbors.jax_md_lists.  docs/jax_md_interop.md has examples.
"""

from jaxdpd.interop.jax_md.neighbor_list import CellNeighborList, neighbor_list
from jaxdpd.interop.jax_md.sllod import SLLODState, sllod
from jaxdpd.interop.jax_md.space import space

__all__ = ["CellNeighborList", "SLLODState", "neighbor_list", "sllod", "space"]
