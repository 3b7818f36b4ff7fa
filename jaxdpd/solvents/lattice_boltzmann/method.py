"""The lattice-Boltzmann solvent component: a fluctuating D3Q19 fluid with friction-
coupled beads; the particles are the beads (jaxdpd.solvents.lattice_boltzmann).

kT ≥ 0 (0 = no fluctuations), grid_spacing a > 0 (box edges whole multiples of it),
time_step τ > 0 (a whole multiple of integrator.dt), mass_density ρ > 0,
kinematic_viscosity ν > 0, kinematic_bulk_viscosity ν_b > 0 (default ν), friction ζ > 0
(bare bead–fluid friction), noise = "uniform" | "gaussian"; units are the scene's own
(e.g. Lennard-Jones units).  The fluid lives in SimState.solvent_state.  A [flow] of
kind "shear" (steady or oscillatory) shears the lattice with a Lees–Edwards boundary
(jaxdpd.solvents.lattice_boltzmann.lees_edwards); the beads then carry peculiar
velocities, as in the particle solvents.
"""

import math
from dataclasses import dataclass
from types import MappingProxyType
from typing import ClassVar

from jaxdpd.solvents import component
from jaxdpd.solvents.lattice_boltzmann import (
    fluid_parameters,
    lattice_nodes,
    md_steps_per_lattice_step,
)
from jaxdpd.solvents.lattice_boltzmann.integrator import coupled_step, initial_fluid_state
from jaxdpd.validation import read_choice, read_number

# Largest thermal Mach number² k_BT/(ρ a³ c_s²) of a lattice-Boltzmann node: beyond it
# the density fluctuations (its square root) make negative densities likely.
MAX_THERMAL_MACH_NUMBER_SQ = 0.1
FLUID_FIELDS = (
    "grid_spacing",
    "time_step",
    "mass_density",
    "kinematic_viscosity",
    "kinematic_bulk_viscosity",
    "friction",
)


@dataclass(frozen=True)
class LatticeBoltzmannParameters(component.SolventParameters):
    """solvent.method = "lattice_boltzmann" (module docstring)."""

    method: ClassVar[str] = "lattice_boltzmann"
    noise: str = "uniform"
    grid_spacing: float = 1.0
    time_step: float = 1.0
    mass_density: float = 1.0
    kinematic_viscosity: float = 1.0
    kinematic_bulk_viscosity: float = 1.0
    friction: float = 1.0


class LatticeBoltzmann(component.SolventMethod):
    """Beads coupled by friction to a lattice-Boltzmann fluid (module docstring): velocity
    Verlet around the friction step, no λ, the beads exchange momentum with the fluid."""

    name = "lattice_boltzmann"
    fields = (*FLUID_FIELDS, "noise")
    flows = ("shear",)
    integrator_lambda = False
    conserves_particle_momentum = False
    heating_advice = "reduce integrator.dt (the beads' friction step) or solvent.time_step"
    unavailable_observables = MappingProxyType(
        {
            "pressure": "of a lattice-Boltzmann scene would need the fluid's stress, which "
            "is not measured"
        }
    )

    def read(self, section) -> LatticeBoltzmannParameters:
        misplaced = sorted({"gamma", "sigma", "pi0", "omega", "delta_pi"} & set(section))
        if misplaced:
            raise ValueError(f"solvent: {misplaced} are not fields of method 'lattice_boltzmann'")
        positive = {"minimum": 0, "exclusive_minimum": True}
        fields = {
            name: read_number(section, name, "solvent", **positive)
            for name in (
                "grid_spacing",
                "time_step",
                "mass_density",
                "kinematic_viscosity",
                "friction",
            )
        }
        fields["kinematic_bulk_viscosity"] = read_number(
            section,
            "kinematic_bulk_viscosity",
            "solvent",
            fields["kinematic_viscosity"],
            **positive,
        )
        kT = read_number(section, "kT", "solvent", 1.0, minimum=0)
        noise = read_choice(section, "noise", "solvent", component.NOISE_LAWS, "uniform")
        a, tau, rho = fields["grid_spacing"], fields["time_step"], fields["mass_density"]
        mach_sq = 3 * kT * tau * tau / (rho * a**5)
        if mach_sq > MAX_THERMAL_MACH_NUMBER_SQ:
            raise ValueError(
                f"solvent: the thermal Mach number² kT/(mass_density a³ c_s²) = {mach_sq:.3g} "
                f"(c_s² = a²/(3 τ²)) exceeds {MAX_THERMAL_MACH_NUMBER_SQ}: node densities "
                "would fluctuate by more than a third and turn negative; reduce time_step or "
                "kT, or raise mass_density or grid_spacing"
            )
        return LatticeBoltzmannParameters(kT=kT, noise=noise, **fields)

    def to_dict(self, parameters) -> dict:
        fields = {name: getattr(parameters, name) for name in FLUID_FIELDS}
        return {"method": self.name, "kT": parameters.kT, "noise": parameters.noise, **fields}

    def default_dt(self, parameters) -> float:
        return parameters.time_step

    def check_integrator(self, parameters, section, integrator) -> None:
        if "lambda" in section:
            raise ValueError(
                "integrator.lambda: the beads in a lattice-Boltzmann solvent move by "
                "velocity Verlet around the friction step (no λ); remove it"
            )

    def check(self, scene) -> None:
        """Box edges whole multiples of the grid spacing, τ a whole multiple of Δt."""
        solvent, lengths, dt = scene.solvent, scene.box.lengths, scene.integrator.dt
        a = solvent.grid_spacing
        for axis, (length, n) in enumerate(zip(lengths, lattice_nodes(lengths, a), strict=True)):
            if n < 1 or not math.isclose(n * a, length, rel_tol=1e-9):
                raise ValueError(
                    f"box.lengths: L_{'xyz'[axis]} = {length:.6g} is not a whole number of "
                    f"solvent.grid_spacing = {a:.6g}; make every edge n a (e.g. "
                    f"{max(1, n) * a:.6g})"
                )
        if scene.flow is not None and lattice_nodes(lengths, a)[1] < 2:
            raise ValueError(
                f"box.lengths: L_y = {lengths[1]:.6g} holds one layer of nodes; a "
                "Lees–Edwards boundary of the lattice needs two or more (L_y ≥ "
                f"{2 * a:.6g} = 2 solvent.grid_spacing)"
            )
        substeps = round(solvent.time_step / dt)
        if substeps < 1 or not math.isclose(substeps * dt, solvent.time_step, rel_tol=1e-9):
            raise ValueError(
                f"solvent.time_step = {solvent.time_step:.6g}: the LB time step must be a "
                f"whole number n ≥ 1 of MD steps integrator.dt = {dt:.6g} (e.g. "
                f"{max(1, substeps) * dt:.6g})"
            )

    def memory(self, scene, box_volume: float, itemsize: int) -> dict:
        side = scene.solvent.grid_spacing
        return {"solvent.grid_spacing": 2 * 19 * itemsize * box_volume / side / side / side}

    def example_scene(self, precision="float64") -> dict:
        """Six Kremer–Grest chains of 10 beads (WCA + FENE) in a 6³ fluctuating fluid
        (the parameters of the packaged lb_chain scene)."""
        return {
            "seed": 5,
            "precision": precision,
            "box": {"lengths": [6.0, 6.0, 6.0]},
            "particles": {"count": 60, "species": [{"name": "monomer"}]},
            "solvent": {
                "method": "lattice_boltzmann",
                "kT": 1.2,
                "grid_spacing": 1.0,
                "time_step": 0.05,
                "mass_density": 0.864,
                "kinematic_viscosity": 2.8,
                "friction": 31.473,
            },
            "pair": {"kind": "wca", "epsilon": 1.0, "sigma": 1.0},
            "polymers": [
                {
                    "species": "monomer",
                    "beads": 10,
                    "bond": {"law": "fene_log_wca", "spring_constant": 7.0, "max_extension": 2.0},
                }
            ],
            "integrator": {"dt": 0.01},
            "neighbors": {"method": "all_pairs"},
        }

    def advance(self, context):
        scene = context.scene
        return coupled_step(
            context.box,
            scene.integrator.dt,
            md_steps_per_lattice_step(scene),
            context.interactions,
            fluid_parameters(scene),
            scene.solvent.friction,
            context.dtype,
            context.masses,
            scene.solvent.noise,
        )

    def initial_solvent_state(self, scene, dtype):
        shear_rate = None if scene.flow is None else scene.flow.shear_rate
        return initial_fluid_state(fluid_parameters(scene), scene.seed, dtype, shear_rate)
