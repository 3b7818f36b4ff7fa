"""Ewald sum of the periodic Oseen trace and the finite-size hydrodynamic radius
(jaxdpd.analysis.periodic_hydrodynamics)."""

import numpy as np
import pytest

from jaxdpd.analysis import periodic_hydrodynamics as ph


def test_ewald_sum_has_the_hasimoto_constant_and_the_background_term():
    """Near the origin the periodic 1/r with neutralising background of a simple cubic
    lattice is φ(r) = 1/r − ξ/L + (2π/3) r²/L³ + O(r⁴/L⁵), ξ = 2.837297 (Hasimoto,
    J. Fluid Mech. 5, 317 (1959); the r² term is the background's, ∇²φ = 4π/L³, the
    cubic symmetry leaving no anisotropic r² term).  At r = 0.02 L the remainder is
    ~ (r/L)⁴/L ≈ 1.6e-7/L; tolerance 1e-6/L."""
    length = 7.0
    rng = np.random.default_rng(2)
    directions = rng.standard_normal((5, 3))
    directions /= np.linalg.norm(directions, axis=1, keepdims=True)
    r = 0.02 * length
    phi = ph.periodic_inverse_distance(r * directions, length)
    expected = 1 / r - ph.HASIMOTO_CONSTANT / length + 2 * np.pi / 3 * r**2 / length**3
    np.testing.assert_allclose(phi, expected, atol=1e-6 / length)


def test_ewald_sum_is_periodic_and_independent_of_the_image_chosen():
    length = 5.0
    r = np.array([[1.2, -0.4, 2.1], [2.4, 2.4, 2.4]])
    shifted = r + length * np.array([[1, -2, 0], [-1, 0, 3]])
    np.testing.assert_allclose(
        ph.periodic_inverse_distance(shifted, length),
        ph.periodic_inverse_distance(r, length),
        rtol=1e-12,
    )


def test_finite_size_radius_of_a_small_chain_against_the_leading_correction():
    """For a chain much smaller than the box, ⟨1/R_H⟩_L = ⟨1/R_H⟩_∞ − ξ/L + O(R²/L³)
    (Dünweg & Kremer, J. Chem. Phys. 99, 6983 (1993); seed eqs. 31, 32 with
    φ ≈ 1/r − ξ/L): a 4-bead chain of size ~1 in a box of 40 leaves (2π/3)⟨r²⟩/L³ ≈
    5e-5 (relative to ξ/L = 0.07); tolerance 1e-4."""
    chain = np.array([[0.0, 0.0, 0.0], [0.9, 0.3, 0.0], [1.5, 1.0, 0.4], [1.4, 1.9, 0.9]])
    length = 40.0
    separations = chain[:, None] - chain[None]
    distance = np.linalg.norm(separations, axis=-1)
    infinite = np.sum(1 / distance[~np.eye(4, dtype=bool)]) / 16
    finite = ph.finite_size_inverse_hydrodynamic_radius(chain, length)
    assert finite == pytest.approx(infinite - ph.HASIMOTO_CONSTANT / length, abs=1e-4)
    d0 = ph.monomer_diffusion_coefficient(0.01, 4, finite, 1.2, 2.42)
    assert d0 == pytest.approx(4 * (0.01 - 1.2 * finite / (6 * np.pi * 2.42)))
