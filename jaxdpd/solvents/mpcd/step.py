"""The MPCD step of a scene: streaming with monomer sub-steps, then the collision.

Composed from exactly what the scene names (jaxdpd.engine.build): SRD in cells or the
solvent-free single-particle rotation; the Maxwell–Boltzmann scaling thermostat only
when asked for; monomer velocity Verlet only when there are monomers; the
collisional virial only when the pressure is observed.
"""

import math

from jaxdpd.engine.integrators import modified_velocity_verlet, mpcd_cycle
from jaxdpd.solvents.mpcd.cells import bin_particles, collision_grid
from jaxdpd.solvents.mpcd.collision import rouse_collision, srd_collision
from jaxdpd.solvents.mpcd.lattice_cells import bin_in_lattice

# Boxes whose collision cells are not the Cartesian grid of
# jaxdpd.solvents.mpcd.cells (by box name): the deforming Kraynik–Reinelt lattice.
LATTICE_BINNINGS = {"kraynik_reinelt": bin_in_lattice}


def mpcd_step(scene, box, interactions, masses, monomers, with_virial: bool, dtype):
    """`step(state) -> state` of an MPCD scene: one collision time h per step.

    Args:
        scene: the Scene (solvent.method = "mpcd").
        box: its box (at rest, Lees–Edwards or Kraynik–Reinelt).
        interactions: the force kernel over the monomer rows
            (jaxdpd.engine.build.force_kernel).
        masses: (N,) masses or None (unit masses).
        monomers: (first, stop) index range of the monomers ((0, 0) for none).
        with_virial: record the collisional (and monomer) virial.
        dtype: floating dtype.
    """
    solvent = scene.solvent
    h = solvent.collision_time
    alpha = solvent.rotation_angle_radians
    if solvent.collision == "particle":
        collide = rouse_collision(alpha, dtype)
    else:
        thermostat_kT = solvent.kT if solvent.thermostat == "maxwell_boltzmann_scaling" else None
        grid = collision_grid(scene.box.lengths, solvent.cell_size)
        binning = LATTICE_BINNINGS.get(box.name, bin_particles)
        collide = srd_collision(
            grid, alpha, masses, thermostat_kT, with_virial, dtype, binning=binning
        )
    first, stop = monomers
    monomer_step, monomer_range = None, None
    if stop > first:
        monomer_range = (first, stop)
        monomer_masses = None if masses is None else masses[first:stop]
        monomer_step = modified_velocity_verlet(
            box,
            scene.integrator.dt,
            0.5,
            interactions,
            solvent.kT,
            dtype,
            monomer_masses,
            closed_system=False,
        )
    substeps = round(h / scene.integrator.dt)
    assert math.isclose(substeps * scene.integrator.dt, h, rel_tol=1e-9)  # validated
    return mpcd_cycle(
        box,
        h,
        substeps,
        monomer_range,
        monomer_step,
        collide,
        solvent.kT,
        dtype,
        masses,
        with_virial,
        closed_system=solvent.collision == "cell",
    )
