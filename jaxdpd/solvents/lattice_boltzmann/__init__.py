"""Fluctuating lattice-Boltzmann solvent with friction-coupled beads.

Modules, one concept each:
    lattice         D3Q19 velocities, weights, orthogonal mode basis
    fluid           MRT collision with thermal noise and forcing; streaming
    counter_noise   counter-based variates per (seed, step, node or bead, stream)
    coupling        trilinear interpolation/spreading, friction (Ornstein–Uhlenbeck) step
    integrator      MD sub-steps of the beads between LB steps; initial fluid
    lees_edwards    the sheared boundary: streaming across it, the beads' images
    linear_theory   exact Fourier analysis: decay rates, lattice Stokeslet, mobility
    state           FluidState (SimState.solvent_state)

References: Ahlrichs & Dünweg, J. Chem. Phys. 111, 8225 (1999) (the coupling, the
seed of this package); Dünweg, Schiller & Ladd, Phys. Rev. E 76, 036704 (2007) and
Adhikari, Stratford, Cates & Wagner, Europhys. Lett. 71, 473 (2005) (the fluctuating
multiple-relaxation-time fluid).
"""

from jaxdpd.solvents.lattice_boltzmann.fluid import FluidParameters


def fluid_parameters(scene) -> FluidParameters:
    """The fluid of a scene with solvent.method = "lattice_boltzmann"."""
    solvent = scene.solvent
    return FluidParameters(
        nodes=lattice_nodes(scene.box.lengths, solvent.grid_spacing),
        grid_spacing=solvent.grid_spacing,
        time_step=solvent.time_step,
        density=solvent.mass_density,
        kinematic_viscosity=solvent.kinematic_viscosity,
        kinematic_bulk_viscosity=solvent.kinematic_bulk_viscosity,
        kT=solvent.kT,
    )


def lattice_nodes(lengths, grid_spacing: float) -> tuple[int, int, int]:
    """Nodes per box edge, n_α = L_α/a (whole numbers, checked by the scene)."""
    return tuple(round(length / grid_spacing) for length in lengths)


def md_steps_per_lattice_step(scene) -> int:
    """n = τ/Δt (a whole number, checked by the scene)."""
    return round(scene.solvent.time_step / scene.integrator.dt)


__all__ = ["FluidParameters", "fluid_parameters", "lattice_nodes", "md_steps_per_lattice_step"]
