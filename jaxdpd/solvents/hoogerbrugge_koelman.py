"""The original DPD update of Hoogerbrugge and Koelman (Europhys. Lett. 19, 155 (1992)).

One step is a collision followed by free propagation over δt:
    p_i ← p_i + Σ_j Ω_ij e_ij,
    Ω_ij = W(r_ij) [Π0 + δΠ_ij − ω (p_i − p_j)·e_ij],
    W(r) = 3 (1 − r/r_c) / (π n r_c³)   for r < r_c (normalised: n ∫ W d³r = 1),
    r_i ← r_i + p_i δt / m,
with e_ij the unit vector from j to i, n the number density and δΠ_ij uniform on
[−Δ, Δ] and symmetric in (i, j).  Defaults Π0 = 1/3, ω = 4/3, Δ = 1/3, δt = 1.

The collision is handed to the integrator as the mean force Ω_ij/δt over the step,
so that it adds to other forces (springs, body forces: Schlijper, Hoogerbrugge &
Manke, J. Rheol. 39, 567 (1995), apply them as impulses F δt in the same update)
and the integrator turns their sum into the impulse δt Σ F.  The collision impulse
Ω_ij itself does not depend on δt: δt changes the model, not its accuracy.

Flows (shear, oscillatory shear, planar elongation): as for every solvent of the
package (docs/conventions.md), the stored velocities are peculiar, c = v − u(r), so
nothing jumps at a Lees–Edwards or Kraynik–Reinelt boundary.  The collision reads
the laboratory relative momentum (p_i − p_j)·e_ij = m [(c_i − c_j) + L r_ij]·e_ij
(the Lees–Edwards relative velocity of the DPD dissipative force, thesis eq. 3.18),
and the free flight is SLLOD without forces in the deforming box: in shear the
laboratory velocity is kept (c ← c − δt L c), in elongation the homogeneous flow is
kept as in the SLLOD integrators (Todd & Daivis, Comput. Phys. Commun. 117, 191
(1999)).  The kinetic stress is averaged over the flight (jaxdpd.engine.integrators:
collide_and_stream, free_flight).  docs/solvent_flows/hoogerbrugge_koelman.md.
"""

from dataclasses import dataclass
from typing import ClassVar

import jax.numpy as jnp

from jaxdpd.engine import noise
from jaxdpd.engine.integrators import collide_and_stream
from jaxdpd.scene_examples import chain_solution_example
from jaxdpd.solvents import component
from jaxdpd.validation import read_number

# Default initial_kT of a Hoogerbrugge–Koelman scene: the kinetic temperature its
# default fluid reaches by itself (Π0 = 1/3, ω = 4/3, Δ = 1/3, n = 3, δt = 1:
# 0.00161 ± 0.000002, benchmarks/accuracy_cost.py, docs/validation/accuracy_cost.md).  Starting
# there instead of at 1 matters for chains: a Hookean spring placed for k_BT = 1
# (√(3/K) ≈ 22 r_c at K = 0.006) or kicked by beads 600 times too hot tears far
# past the box before the fluid's friction (≈ ω Σ_j W_ij ≈ 4/3 per collision) cools
# it.  Other parameter sets reach other temperatures: measure it and set initial_kT.
HOOGERBRUGGE_KOELMAN_KT = 0.0016


def collision_weight(weight, density, cutoff):
    """W(r) = 3 (1 − r/r_c) / (π n r_c³), given the DPD weight 1 − r/r_c."""
    return 3 * weight / (jnp.pi * density * cutoff**3)


def collision_magnitude(w, relative_normal_momentum, delta_pi, pi0, omega):
    """Scalar law Ω_ij = W [Π0 + δΠ_ij − ω (p_i − p_j)·e_ij]."""
    return w * (pi0 + delta_pi - omega * relative_normal_momentum)


def hoogerbrugge_koelman_term(density, cutoff, pi0, omega, delta_pi_half_width, mass, dt, dtype):
    """Collision term for the composed step (context.velocities, context.key):
    `term(geometry, context) -> {"collision": Ω_ij/δt}`, the pair's mean force over
    the step δt (module docstring).

    Args:
        density: n of W(r), particles per r_c³.
        cutoff: r_c.
        pi0, omega, delta_pi_half_width: Π0, ω, Δ.
        mass: particle mass m (the relative momentum is m (v_i − v_j)·e_ij).
        dt: δt.
        dtype: floating dtype.
    """
    pi0_, omega_ = jnp.asarray(pi0, dtype), jnp.asarray(omega, dtype)
    width = jnp.asarray(delta_pi_half_width, dtype)
    dt_ = jnp.asarray(dt, dtype)

    def term(geometry, context):
        delta_pi = noise.pair_uniform(context.key, *geometry.identity_pairs(), -width, width, dtype)
        momentum = geometry.relative_velocity_along_pair(context.velocities) * mass
        w = collision_weight(geometry.weight, density, cutoff)
        return {"collision": collision_magnitude(w, momentum, delta_pi, pi0_, omega_) / dt_}

    return term


@dataclass(frozen=True)
class HoogerbruggeKoelmanParameters(component.SolventParameters):
    """solvent.method = "hoogerbrugge_koelman".

    `kT` is the scene's initial_kT: the model sets no temperature (its own follows
    from pi0, omega, delta_pi and n), so this is the temperature the velocities start
    at, the Hookean bond length chains are placed with and the scale of the runaway
    check.  `weight_density` is the n of W(r), None for the box's N/V.
    """

    method: ClassVar[str] = "hoogerbrugge_koelman"
    kT: float = HOOGERBRUGGE_KOELMAN_KT
    pi0: float = 1.0 / 3.0
    omega: float = 4.0 / 3.0
    delta_pi: float = 1.0 / 3.0
    weight_density: float | None = None


class HoogerbruggeKoelman(component.SolventMethod):
    """The original DPD update (module docstring): pi0, omega, delta_pi (half-width),
    weight_density n > 0 (default N/V), initial_kT > 0; a collision and free flight
    of unit masses, at rest or in flow, with its own conservative part (no [pair])."""

    name = "hoogerbrugge_koelman"
    fields = ("pi0", "omega", "delta_pi", "weight_density", "initial_kT")
    flows = ("shear", "planar_elongation")
    pair_forces = False
    sets_temperature = False
    uses_neighbor_list = True
    decomposition = "forces_before_flight"
    initial_forces = False  # collide_and_stream computes the forces at each step

    def read(self, section) -> HoogerbruggeKoelmanParameters:
        if "kT" in section:
            raise ValueError(
                f"solvent: ['kT'] belongs to the methods that set a temperature, not "
                f"{self.name!r}, whose temperature follows from pi0, omega, delta_pi and the "
                "density; give solvent.initial_kT for the starting velocities and chain "
                "placement"
            )
        positive = {"minimum": 0, "exclusive_minimum": True}
        return HoogerbruggeKoelmanParameters(
            kT=read_number(section, "initial_kT", "solvent", HOOGERBRUGGE_KOELMAN_KT, **positive),
            pi0=read_number(section, "pi0", "solvent", 1.0 / 3.0),
            omega=read_number(section, "omega", "solvent", 4.0 / 3.0, minimum=0),
            delta_pi=read_number(section, "delta_pi", "solvent", 1.0 / 3.0, minimum=0),
            weight_density=read_number(section, "weight_density", "solvent", None, **positive),
        )

    def to_dict(self, parameters) -> dict:
        data = {
            "method": self.name,
            "pi0": parameters.pi0,
            "omega": parameters.omega,
            "delta_pi": parameters.delta_pi,
            "initial_kT": parameters.kT,
        }
        if parameters.weight_density is not None:
            data["weight_density"] = parameters.weight_density
        return data

    def default_dt(self, parameters) -> float:
        return 1.0

    def check(self, scene) -> None:
        if any(s.mass != 1.0 for s in scene.particles.species):
            raise ValueError(
                "particles.species[].mass: the Hoogerbrugge–Koelman update is written for "
                "unit masses; remove the masses or use solvent.method = 'dpd'"
            )

    def pair_terms(self, scene, dtype) -> list:
        solvent = scene.solvent
        return [
            hoogerbrugge_koelman_term(
                solvent.weight_density or scene.particles.density,
                scene.cutoff,
                solvent.pi0,
                solvent.omega,
                solvent.delta_pi,
                1.0,
                scene.integrator.dt,
                dtype,
            )
        ]

    def example_scene(self, precision="float64") -> dict:
        """300 particles at n = 3 in the default fluid (Π0 = 1/3, ω = 4/3, Δ = 1/3, δt = 1,
        started at its own temperature) with 15 Hookean 4-bead chains, K = 0.006."""
        return chain_solution_example(precision, {"method": "hoogerbrugge_koelman"}, 0.006)

    def advance(self, context):
        scene = context.scene
        return collide_and_stream(
            context.box,
            scene.integrator.dt,
            context.interactions,
            scene.solvent.kT,
            context.dtype,
            context.with_virial,
            context.ownership,
        )
