"""The MPCD solvent component: stochastic rotation dynamics (Mussawisade et al. 2005 §II).

kT > 0 (initial velocities, thermostat), cell_size a > 0 (every box edge a whole
multiple ≥ 2), rotation_angle α in (0, 180] degrees (default 130), collision_time h > 0
(default 0.1), thermostat = "none" | "maxwell_boltzmann_scaling" (cell level, Huang et
al. 2010), collision = "cell" (SRD) | "particle" (the solvent-free Rouse variant, §IV.A:
every particle must be a monomer); particles per cell ρ = particles.density · a³.
Solvent particles stream freely; monomers move by velocity Verlet with integrator.dt =
h_p (h/h_p a whole number, default h_p = h) and join the collisions with their species
masses.  Only the monomers feel forces: the force kernel covers their index range.
Flows: Lees–Edwards shear (cells.bin_particles) and planar elongation, whose cells
are those of the Kraynik–Reinelt lattice coordinates (lattice_cells;
docs/solvent_flows/mpcd.md: there η̄1 = 4η_kin + 2κη_coll, not 4 × the shear η).
"""

import math
from dataclasses import dataclass
from types import MappingProxyType
from typing import ClassVar

from jaxdpd.solvents import component
from jaxdpd.solvents.mpcd.cells import collision_grid
from jaxdpd.solvents.mpcd.step import mpcd_step
from jaxdpd.validation import read_choice, read_number

THERMOSTATS = ("none", "maxwell_boltzmann_scaling")
COLLISIONS = ("cell", "particle")


@dataclass(frozen=True)
class MPCDParameters(component.SolventParameters):
    """solvent.method = "mpcd" (module docstring); rotation_angle in degrees."""

    method: ClassVar[str] = "mpcd"
    cell_size: float = 1.0
    rotation_angle: float = 130.0
    collision_time: float = 0.1
    thermostat: str = "none"
    collision: str = "cell"

    @property
    def rotation_angle_radians(self) -> float:
        """The rotation angle α in radians (the scene gives degrees)."""
        return math.radians(self.rotation_angle)


class MPCD(component.SolventMethod):
    """Multi-particle collision dynamics (module docstring)."""

    name = "mpcd"
    fields = ("cell_size", "rotation_angle", "collision_time", "thermostat", "collision")
    flows = ("shear", "planar_elongation")
    heating_advice = (
        "reduce solvent.collision_time, lower the flow rate, or set solvent.thermostat "
        "= 'maxwell_boltzmann_scaling' (SRD without a thermostat heats under flow)"
    )
    unavailable_observables = MappingProxyType(
        {
            "spring_pairs": "is not available with solvent.method = 'mpcd' (its monomer "
            "step does not carry the spring-pair list)"
        }
    )

    def read(self, section) -> MPCDParameters:
        path = "solvent"
        positive = {"minimum": 0, "exclusive_minimum": True}
        return MPCDParameters(
            kT=read_number(section, "kT", path, 1.0, **positive),
            cell_size=read_number(section, "cell_size", path, 1.0, **positive),
            rotation_angle=read_number(
                section, "rotation_angle", path, 130.0, **positive, maximum=180
            ),
            collision_time=read_number(section, "collision_time", path, 0.1, **positive),
            thermostat=read_choice(section, "thermostat", path, THERMOSTATS, "none"),
            collision=read_choice(section, "collision", path, COLLISIONS, "cell"),
        )

    def to_dict(self, parameters) -> dict:
        return {"method": "mpcd", "kT": parameters.kT} | {
            key: getattr(parameters, key) for key in self.fields
        }

    def default_dt(self, parameters) -> float:
        return parameters.collision_time

    def check_integrator(self, parameters, section, integrator) -> None:
        """h_p divides h; plain velocity Verlet (λ = 0.5)."""
        h, dt, lam = parameters.collision_time, integrator.dt, integrator.lambda_
        substeps = round(h / dt)
        if substeps < 1 or abs(substeps * dt - h) > 1e-9 * h:
            raise ValueError(
                f"integrator.dt = {dt!r}: the monomer sub-step h_p must divide "
                f"solvent.collision_time h = {h!r} a whole number of times (h/h_p = "
                f"{h / dt:.6g}); e.g. dt = {h / max(1, math.ceil(h / dt)):.6g}"
            )
        if lam != 0.5:
            raise ValueError(
                f"integrator.lambda = {lam!r}: MPCD monomers move by plain velocity "
                "Verlet (λ = 0.5; Mussawisade et al. §II); remove integrator.lambda"
            )

    def check(self, scene) -> None:
        """The collision grid; monomers in one index range; a pair force needs them."""
        solvent = scene.solvent
        collision_grid(scene.box.lengths, solvent.cell_size)
        chained = {p.species for p in scene.polymers}
        names = list(scene.species_names)
        positions = [k for k, name in enumerate(names) if name in chained]
        if positions and positions[-1] - positions[0] + 1 != len(positions):
            raise ValueError(
                f"particles.species: with solvent.method = 'mpcd' the chained species "
                f"{sorted(chained)} must be adjacent in the species list (monomers form one "
                f"index range); reorder {names}"
            )
        if solvent.collision == "particle" and set(names) != chained:
            free = [name for name in names if name not in chained]
            raise ValueError(
                f"solvent.collision = 'particle' is the solvent-free Rouse variant (every "
                f"monomer's velocity rotated alone); species {free} are not chained: give "
                "them [[polymers]] entries, remove them, or use collision = 'cell'"
            )
        if scene.pair is not None and not chained:
            raise ValueError(
                "pair: with solvent.method = 'mpcd' pair forces act among the [[polymers]] "
                "species only (solvent particles feel no forces); add [[polymers]] or remove "
                "the [pair] section"
            )
        if scene.spring_repulsion is not None:
            raise ValueError(
                "spring_repulsion: not available with solvent.method = 'mpcd' (its monomer "
                "step does not carry the spring-pair list); remove it"
            )

    def step_time(self, scene) -> float:
        """The collision time h (the monomer sub-steps integrator.dt run inside)."""
        return scene.solvent.collision_time

    def memory(self, scene, box_volume: float, itemsize: int) -> dict:
        # Divided edge by edge: a tiny size overflows to inf (refused), never to 0/0.
        side = scene.solvent.cell_size
        return {"solvent.cell_size": 4 * itemsize * box_volume / side / side / side}

    def force_range(self, scene, blocks) -> tuple[int, int]:
        """The monomers' index range ((0, 0) without polymers)."""
        if not blocks:
            return 0, 0
        return min(b.first for b in blocks), max(b.stop for b in blocks)

    def example_scene(self, precision="float64") -> dict:
        """An SRD fluid of 5 particles per cell in a 4³ box with two Gaussian chains of
        10 monomers of mass 5 (h = 0.1, monomer sub-step 0.01)."""
        return {
            "seed": 5,
            "precision": precision,
            "box": {"lengths": [4.0, 4.0, 4.0]},
            "particles": {
                "count": 340,
                "species": [
                    {"name": "solvent", "count": 320},
                    {"name": "monomer", "count": 20, "mass": 5.0},
                ],
            },
            "solvent": {"method": "mpcd", "collision_time": 0.1, "kT": 1.0},
            "integrator": {"dt": 0.01},
            "polymers": [
                {
                    "species": "monomer",
                    "beads": 10,
                    "bond": {"law": "hookean", "spring_constant": 3.0},
                }
            ],
        }

    def advance(self, context):
        return mpcd_step(
            context.scene,
            context.box,
            context.interactions,
            context.masses,
            context.force_range,
            context.with_virial,
            context.dtype,
        )
