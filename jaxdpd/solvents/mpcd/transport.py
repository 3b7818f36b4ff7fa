"""Analytic transport properties of the SRD fluid and of a polymer in it.

Mussawisade, Ripoll, Winkler & Gompper, J. Chem. Phys. 123, 144905 (2005), §III:

    η_coll = m ρ (1 − 1/ρ)(1 − cos α) / (18 h a)                               (eq. 6)
    η_kin  = k_BT h ρ / a³ · [5ρ / ((4 − 2 cos α − 2 cos 2α)(ρ − 1)) − ½]
    γ_α    = (2/3)(1 − cos α)                                                  (eq. 9)
    ⟨v_cm(nh)·v_cm(0)⟩ = 3 k_BT/(M N_m) (1 − γ)^n                              (eq. 7)
    ⟨Δr_cm²(nh)⟩ = 6 k_BT h²/(M N_m) [(1/γ − ½) n − ((1 − γ) − (1 − γ)^{n+1})/γ²] (eq. 11)
    D_cm = k_BT h/(M N_m) (1/γ − ½)                                            (eq. 12)

ρ is the mean number of solvent particles per cell, a the cell size, h the collision
time, α the rotation angle, M the monomer mass and N_m the chain length.  η_kin rests
on the molecular-chaos assumption.  With Poisson-distributed cell occupancies (a
random grid shift over an ideal gas) the factor ρ − 1 of η_coll becomes
ρ − 1 + e^{−ρ} (cells never hold −1 particles; tests/test_mpcd_transport derives
it); `collisional_viscosity(poisson=True)` selects that form.  Eqs. 7, 11 and 12 hold
for a chain whose centre-of-mass velocity keeps on average the fraction 1 − γ of
itself per collision (molecular chaos); γ is eq. 8 in a solvent and exactly γ_α in
the solvent-free Rouse variant.
"""

import math
from dataclasses import dataclass


def rotation_factor(rotation_angle: float) -> float:
    """γ_α = (2/3)(1 − cos α) (eq. 9): a velocity rotated by α about a uniformly random
    axis keeps on average the fraction 1 − γ_α of itself.

    Args:
        rotation_angle: α in radians.
    """
    return 2.0 / 3.0 * (1.0 - math.cos(rotation_angle))


@dataclass(frozen=True)
class SRDFluid:
    """The parameters of an SRD fluid that enter eq. 6.

    Attributes:
        particles_per_cell: ρ, mean number of solvent particles per cell.
        rotation_angle: α in radians.
        collision_time: h.
        kT: k_BT.
        cell_size: a.
        mass: solvent particle mass m.
    """

    particles_per_cell: float
    rotation_angle: float
    collision_time: float
    kT: float = 1.0
    cell_size: float = 1.0
    mass: float = 1.0

    @classmethod
    def from_scene(cls, scene) -> "SRDFluid":
        """The fluid of an MPCD scene (ρ = particles.density · a³, unit solvent mass)."""
        solvent = scene.solvent
        return cls(
            scene.particles.density * solvent.cell_size**3,
            solvent.rotation_angle_radians,
            solvent.collision_time,
            solvent.kT,
            solvent.cell_size,
        )

    @property
    def mass_density(self) -> float:
        """ϱ = m ρ / a³."""
        return self.mass * self.particles_per_cell / self.cell_size**3

    def _occupancy(self, poisson: bool) -> float:
        """ρ − 1, or its Poisson average ρ − 1 + e^{−ρ} (the mean of max(n − 1, 0))."""
        rho = self.particles_per_cell
        return rho - 1 + (math.exp(-rho) if poisson else 0.0)

    def collisional_viscosity(self, poisson: bool = False) -> float:
        """η_coll of eq. 6 (units of mass/(length·time)); `poisson`: ρ − 1 + e^{−ρ} for
        ρ − 1 (module docstring)."""
        return (
            self.mass
            * self._occupancy(poisson)
            * (1 - math.cos(self.rotation_angle))
            / (18 * self.collision_time * self.cell_size)
        )

    def kinetic_viscosity(self) -> float:
        """η_kin of eq. 6 (molecular chaos, number fluctuations neglected)."""
        rho, alpha = self.particles_per_cell, self.rotation_angle
        denominator = (4 - 2 * math.cos(alpha) - 2 * math.cos(2 * alpha)) * (rho - 1)
        prefactor = self.kT * self.collision_time * rho / self.cell_size**3
        return prefactor * (5 * rho / denominator - 0.5)

    def shear_viscosity(self) -> float:
        """η = η_kin + η_coll (eq. 6)."""
        return self.kinetic_viscosity() + self.collisional_viscosity()

    def kinematic_viscosity(self) -> float:
        """ν = η/ϱ of eq. 6 (what the decay of transverse momentum measures)."""
        return self.shear_viscosity() / self.mass_density


def center_of_mass_vacf(n, decay_factor: float, kT: float, chain_mass: float):
    """⟨v_cm(nh)·v_cm(0)⟩ = 3 k_BT/(M N_m) (1 − γ)^n (eq. 7).

    Args:
        n: collision count(s) (int or array).
        decay_factor: γ.
        kT: k_BT.
        chain_mass: M N_m.
    """
    return 3 * kT / chain_mass * (1 - decay_factor) ** n


def center_of_mass_msd(n, decay_factor: float, collision_time: float, kT: float, chain_mass: float):
    """⟨(r_cm(nh) − r_cm(0))²⟩ of eq. 11.

    Args:
        n: collision count(s) (int or array).
        decay_factor: γ.
        collision_time: h.
        kT: k_BT.
        chain_mass: M N_m.
    """
    g = decay_factor
    return (
        6
        * kT
        * collision_time**2
        / chain_mass
        * ((1 / g - 0.5) * n - ((1 - g) - (1 - g) ** (n + 1)) / g**2)
    )


def center_of_mass_diffusion(
    decay_factor: float, collision_time: float, kT: float, chain_mass: float
):
    """D_cm = k_BT h/(M N_m) (1/γ − ½) (eq. 12)."""
    return kT * collision_time / chain_mass * (1 / decay_factor - 0.5)
