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
random grid shift over an ideal gas) the factor ρ − 1 becomes ρ − 1 + e^{−ρ} (cells
never hold −1 particles: tests/test_mpcd_transport derives it); `poisson=True`
selects that form.  Eqs. 7, 11 and 12 hold for a chain whose centre-of-mass velocity keeps on
average the fraction 1 − γ of itself per collision (molecular chaos); γ is eq. 8
in a solvent and exactly γ_α in the solvent-free Rouse variant.
"""

import math


def rotation_factor(rotation_angle: float) -> float:
    """γ_α = (2/3)(1 − cos α) (eq. 9): a velocity rotated by α about a uniformly random
    axis keeps on average the fraction 1 − γ_α of itself.

    Args:
        rotation_angle: α in radians.
    """
    return 2.0 / 3.0 * (1.0 - math.cos(rotation_angle))


def _occupancy_factor(particles_per_cell: float, poisson: bool) -> float:
    """ρ − 1, or its Poisson average ρ − 1 + e^{−ρ} (the mean of max(n − 1, 0))."""
    rho = particles_per_cell
    return rho - 1 + (math.exp(-rho) if poisson else 0.0)


def collisional_viscosity(
    particles_per_cell: float,
    rotation_angle: float,
    collision_time: float,
    cell_size: float = 1.0,
    mass: float = 1.0,
    poisson: bool = False,
) -> float:
    """η_coll of eq. 6 (units of mass/(length·time)).

    Args:
        particles_per_cell: ρ.
        rotation_angle: α in radians.
        collision_time: h.
        cell_size: a.
        mass: solvent particle mass m.
        poisson: use ρ − 1 + e^{−ρ} for ρ − 1 (module docstring).
    """
    occupancy = _occupancy_factor(particles_per_cell, poisson)
    return mass * occupancy * (1 - math.cos(rotation_angle)) / (18 * collision_time * cell_size)


def kinetic_viscosity(
    particles_per_cell: float,
    rotation_angle: float,
    collision_time: float,
    kT: float = 1.0,
    cell_size: float = 1.0,
    poisson: bool = False,
) -> float:
    """η_kin of eq. 6 (molecular chaos).

    Args:
        particles_per_cell: ρ.
        rotation_angle: α in radians.
        collision_time: h.
        kT: k_BT.
        cell_size: a.
        poisson: use ρ − 1 + e^{−ρ} for ρ − 1 (module docstring).
    """
    rho, alpha = particles_per_cell, rotation_angle
    denominator = (4 - 2 * math.cos(alpha) - 2 * math.cos(2 * alpha)) * _occupancy_factor(
        rho, poisson
    )
    return kT * collision_time * rho / cell_size**3 * (5 * rho / denominator - 0.5)


def shear_viscosity(
    particles_per_cell: float,
    rotation_angle: float,
    collision_time: float,
    kT: float = 1.0,
    cell_size: float = 1.0,
    mass: float = 1.0,
    poisson: bool = False,
) -> float:
    """η = η_kin + η_coll (eq. 6)."""
    return kinetic_viscosity(
        particles_per_cell, rotation_angle, collision_time, kT, cell_size, poisson
    ) + collisional_viscosity(
        particles_per_cell, rotation_angle, collision_time, cell_size, mass, poisson
    )


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
