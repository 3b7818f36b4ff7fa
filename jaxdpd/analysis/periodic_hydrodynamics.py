"""Hydrodynamic interactions with periodic images: the finite-size corrected
hydrodynamic radius of a chain and the monomer diffusion coefficient it implies.

In a cubic periodic box of side L the Oseen diffusion tensor of two beads is (Ahlrichs
& Dünweg, J. Chem. Phys. 111, 8225 (1999), eq. 28)

    D(r) = (k_BT/(η L³)) Σ_{k≠0} (1 − k̂k̂)/k² e^{ik·r},   Tr D(r) = (k_BT/(2πη)) φ(r),

with φ(r) = (4π/L³) Σ_{k≠0} e^{ik·r}/k², the periodic 1/r with a uniform neutralising
background, summed here by Ewald's method (Allen & Tildesley, Computer Simulation of
Liquids, 2nd ed. (2017), §6.2):

    φ(r) = Σ_n erfc(α|r + nL|)/|r + nL| + (4π/L³) Σ_{k≠0} e^{−k²/4α²} cos(k·r)/k²
           − π/(α² L³).

For r → 0, φ(r) − 1/r → −ξ/L with ξ = 2.837297 (the constant of Hasimoto, J. Fluid
Mech. 5, 317 (1959)); so a bead's interaction with its own images lowers its
mobility by ξ k_BT/(6πηL) (eq. 29).  The centre-of-mass diffusion coefficient of an
N-bead chain is then (eqs. 30–32)

    D_CM,L = D₀/N + (k_BT/(6πη)) ⟨1/R_H⟩_L,
    ⟨1/R_H⟩_L = −ξ/(N L) + (1/N²) Σ_{i≠j} ⟨φ(r_ij)⟩,

the Kirkwood formula (eq. 27) with the infinite-system ⟨1/R_H⟩_∞ = (1/N²) Σ_{i≠j}
⟨1/r_ij⟩ replaced by its periodic counterpart.  Host-side analysis (NumPy arrays,
float64; erfc from jax.scipy).
"""

import itertools
import math

import numpy as np
from jax.scipy.special import erfc

HASIMOTO_CONSTANT = 2.837297
_SPLITTING = 3.5  # α L: real-space images |n| ≤ 3, wave vectors |m| ≤ 6 → ~1e-12
_IMAGES = np.array(list(itertools.product(range(-3, 4), repeat=3)), np.float64)
_WAVES = np.array([m for m in itertools.product(range(-6, 7), repeat=3) if any(m)], np.float64)


def periodic_inverse_distance(separations, box_length: float) -> np.ndarray:
    """φ(r): the Ewald sum of 1/|r + nL| over a cubic lattice with neutralising
    background (module docstring), to ~1e-12 relative.

    Args:
        separations: (..., 3) vectors r (length units), any image.
        box_length: L.
    Returns:
        (...) φ (1/length).
    """
    r = np.asarray(separations, np.float64)
    length = float(box_length)
    r = r - length * np.round(r / length)
    alpha = _SPLITTING / length
    shifted = r[..., None, :] + length * _IMAGES
    distance = np.linalg.norm(shifted, axis=-1)
    safe = np.where(distance > 0, distance, 1.0)
    screened = np.asarray(erfc(alpha * safe), np.float64) / safe
    real = np.where(distance > 0, screened, 0.0).sum(axis=-1)
    k = 2 * np.pi * _WAVES / length
    k_sq = np.sum(k * k, axis=1)
    weights = 4 * np.pi / length**3 * np.exp(-k_sq / (4 * alpha**2)) / k_sq
    reciprocal = np.cos(r @ k.T) @ weights
    return real + reciprocal - np.pi / (alpha**2 * length**3)


def finite_size_inverse_hydrodynamic_radius(chains, box_length: float) -> np.ndarray:
    """⟨1/R_H⟩_L of each chain configuration (seed eqs. 31, 32).

    Args:
        chains: (..., N, 3) bead positions of each chain (any images: only
            separations enter, folded to the minimum image).
        box_length: L of the cubic box.
    Returns:
        (...) −ξ/(N L) + (1/N²) Σ_{i≠j} φ(r_ij) (1/length).
    """
    x = np.asarray(chains, np.float64)
    n = x.shape[-2]
    i, j = np.triu_indices(n, 1)
    pairs = periodic_inverse_distance(x[..., i, :] - x[..., j, :], box_length)
    return -HASIMOTO_CONSTANT / (n * box_length) + 2 * pairs.sum(axis=-1) / n**2


def monomer_diffusion_coefficient(
    center_of_mass_diffusion: float,
    n_beads: int,
    inverse_hydrodynamic_radius: float,
    kT: float,
    viscosity: float,
) -> float:
    """D₀ from a measured D_CM,L by the Kirkwood formula with periodic images
    (seed eq. 32 solved for D₀): D₀ = N [D_CM,L − k_BT ⟨1/R_H⟩_L/(6πη)].

    Args:
        center_of_mass_diffusion: D_CM,L (length²/time).
        n_beads: N.
        inverse_hydrodynamic_radius: ⟨1/R_H⟩_L (`finite_size_inverse_hydrodynamic_radius`
            averaged over configurations).
        kT: k_BT; viscosity: the dynamic viscosity η = ρ ν.
    """
    hydrodynamic = kT * inverse_hydrodynamic_radius / (6 * math.pi * viscosity)
    return n_beads * (center_of_mass_diffusion - hydrodynamic)
