"""Bond laws: forces are −∇U (autodiff), Newton's third law, FENE limits.

Reference: each law's potential as written in jaxdpd.forces.bonds (thesis eqs. 2.25, 2.26;
Mussawisade et al. eq. 4; Ahlrichs & Dünweg eq. 8).
"""

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from jaxdpd.forces import bonds
from jaxdpd.geometry.boxes import PeriodicBox, make_box
from jaxdpd.geometry.chain_topology import ChainBlock, chain_coordinates

LAWS = {
    "hookean": bonds.bond_law({"law": "hookean", "spring_constant": 2.0}, kT=1.0),
    "fraenkel": bonds.bond_law(
        {"law": "fraenkel", "spring_constant": 30.0, "rest_length": 0.8}, kT=1.0
    ),
    "fene": bonds.bond_law({"law": "fene", "spring_constant": 0.5, "max_extension": 5.0}, kT=1.0),
    "fene_log_wca": bonds.bond_law(
        {"law": "fene_log_wca", "spring_constant": 30.0, "max_extension": 1.5}, kT=1.0
    ),
}
BOX = PeriodicBox((12.0, 13.0, 14.0))


def _chains(seed, n_chains=5, beads=6):
    """Random-walk chains with steps of random direction and length in [0.5, 1.2]
    (below every law's maximum extension)."""
    rng = np.random.default_rng(seed)
    directions = rng.normal(size=(n_chains, beads - 1, 3))
    directions /= np.linalg.norm(directions, axis=-1, keepdims=True)
    steps = directions * rng.uniform(0.5, 1.2, (n_chains, beads - 1, 1))
    start = rng.uniform(0, 12, (n_chains, 1, 3))
    unwrapped = np.concatenate([start, start + np.cumsum(steps, axis=1)], axis=1)
    lengths = np.asarray(BOX.lengths)
    image = np.floor(unwrapped / lengths).astype(np.int32)
    return jnp.asarray(unwrapped - image * lengths), jnp.asarray(image), unwrapped


@pytest.mark.parametrize("name", list(LAWS))
def test_force_is_minus_gradient_of_energy(name):
    law = LAWS[name]
    positions, image, unwrapped = _chains(1)

    def energy(unwrapped_positions):
        springs = unwrapped_positions[:, 1:] - unwrapped_positions[:, :-1]
        return jnp.sum(law.energy(jnp.sum(springs**2, axis=-1)))

    expected = -jax.grad(energy)(jnp.asarray(unwrapped))
    result = bonds.chain_bond_forces(BOX, positions, image, law, with_virial=True)
    # Round-off scale: float64 ε times the largest force (the WCA core is steep).
    scale = 1e-13 * float(jnp.max(jnp.abs(expected)))
    np.testing.assert_allclose(result.forces, expected, rtol=1e-10, atol=scale)
    # Newton's third law: the springs exert no net force on a chain.
    np.testing.assert_allclose(jnp.sum(result.forces, axis=1), 0.0, atol=scale)
    # Virial Σ r_ij ⊗ F_ij equals Σ_k r_k ⊗ F_k for the unwrapped chain (no net force).
    virial = jnp.einsum("cka,ckb->ab", unwrapped, result.forces)
    np.testing.assert_allclose(result.virial, virial, rtol=1e-10, atol=100 * scale)
    assert not bool(result.overstretched) and not bool(result.past_half_box)


def test_scalar_laws_match_their_formulas():
    """Tension T(Q) = Q · stiffness at a few lengths, against the textbook formulas."""
    q = jnp.asarray([0.3, 0.9, 1.2])
    q_sq = q * q
    np.testing.assert_allclose(q * LAWS["hookean"].stiffness(q_sq), 2.0 * q)
    np.testing.assert_allclose(q * LAWS["fraenkel"].stiffness(q_sq), 30.0 * (q - 0.8))
    np.testing.assert_allclose(q * LAWS["fene"].stiffness(q_sq), 0.5 * q / (1 - q_sq / 25.0))
    wca = -24 * (2 / q**13 - 1 / q**7) * (q < 2 ** (1 / 6))
    np.testing.assert_allclose(
        q * LAWS["fene_log_wca"].stiffness(q_sq), 30.0 * q / (1 - q_sq / 2.25) + wca
    )


def test_fene_past_maximum_extension_is_flagged_and_finite():
    law = LAWS["fene"]
    positions = jnp.asarray([[[1.0, 1.0, 1.0], [6.2, 1.0, 1.0]]])  # Q = 5.2 > Q0 = 5
    result = bonds.chain_bond_forces(
        PeriodicBox((20.0, 20.0, 20.0)), positions, jnp.zeros((1, 2, 3), jnp.int32), law, False
    )
    assert bool(result.overstretched)
    assert np.all(np.isfinite(result.forces))


def test_spring_longer_than_half_box_follows_the_image_counters():
    """Beads 7 apart along x in a box of 12 (thesis §3.2.4: unwrapped coordinates
    r + n L): the periodic box at rest takes the spring from the image counters, so
    the Hookean force is H Q = 2 × 7 toward the partner, not the minimum image's 5 the
    other way, and nothing is ambiguous.  Where something reads springs by minimum
    image (`half_box_limit`) it is flagged; a Lees–Edwards box, which cannot unwrap,
    flags a spring as it grows past 0.45 of an edge (5.6 of 12)."""
    positions = jnp.asarray([[[1.0, 1.0, 1.0], [8.0, 1.0, 1.0]]])
    image = jnp.zeros((1, 2, 3), jnp.int32)
    result = bonds.chain_bond_forces(BOX, positions, image, LAWS["hookean"], False)
    assert not bool(result.past_half_box)
    np.testing.assert_allclose(result.forces[0, 0], [14.0, 0, 0])
    np.testing.assert_allclose(result.forces[0, 1], [-14.0, 0, 0])
    limited = bonds.chain_bond_forces(BOX, positions, image, LAWS["hookean"], False, True)
    assert bool(limited.past_half_box)
    lees_edwards = make_box("lees_edwards", BOX.lengths)
    sheared = lees_edwards.bind(lees_edwards.initial_state(jnp.float64))
    growing = jnp.asarray([[[1.0, 1.0, 1.0], [6.6, 1.0, 1.0]]])
    assert bool(
        bonds.chain_bond_forces(sheared, growing, image, LAWS["hookean"], False).past_half_box
    )
    crossing = jnp.asarray([[[11.5, 1.0, 1.0], [0.5, 1.0, 1.0]]])  # 1 apart across x = L
    crossing_image = jnp.asarray([[[0, 0, 0], [1, 0, 0]]], jnp.int32)
    result = bonds.chain_bond_forces(BOX, crossing, crossing_image, LAWS["hookean"], False, True)
    assert not bool(result.past_half_box)
    np.testing.assert_allclose(result.forces[0, 0], [2.0, 0, 0])


def test_chain_coordinates_follow_the_image_counters():
    """A trimer whose springs reach 1.3 along x in a box of edge 2.2 (a chain of a
    few beads in a box of a few r_c, as in Schlijper et al. 1995): with image
    counters its coordinates are the unwrapped ones; the minimum image folds them."""
    box = PeriodicBox((2.2, 2.2, 2.2))
    unwrapped = np.asarray([[0.3, 1.0, 1.0], [1.6, 1.3, 1.0], [2.9, 1.6, 1.0]]) + [2.0, 0, 0]
    image = np.floor(unwrapped / 2.2).astype(np.int32)
    block = ChainBlock("P", 0, 1, 3, LAWS["hookean"])
    chains = chain_coordinates(box, jnp.asarray(unwrapped - 2.2 * image), block, jnp.asarray(image))
    np.testing.assert_allclose(np.diff(chains[0], axis=0), np.diff(unwrapped, axis=0), atol=1e-12)
    folded = chain_coordinates(box, jnp.asarray(unwrapped - 2.2 * image), block)
    assert not np.allclose(np.diff(folded[0], axis=0), np.diff(unwrapped, axis=0))


def test_placement_lengths():
    """FENE dumbbells start at their exact ⟨Q²⟩^{1/2} = Q0 √(3/(b+5)) (thesis eq. 4.8);
    the Kremer–Grest bond at its energy minimum ≈ 0.96σ for k = 30, R0 = 1.5."""
    b = 0.5 * 25.0
    assert LAWS["fene"].placement_length == pytest.approx(5.0 * np.sqrt(3 / (b + 5)))
    assert LAWS["hookean"].placement_length == pytest.approx(np.sqrt(1.5))
    assert LAWS["fraenkel"].placement_length == 0.8
    assert 0.95 < LAWS["fene_log_wca"].placement_length < 0.98


def test_harmonic_is_the_fraenkel_law_under_its_md_name():
    """U = ½ k (Q − r0)² under both names (jaxdpd.forces.bonds docstring)."""
    parameters = {"spring_constant": 30.0, "rest_length": 0.8}
    harmonic = bonds.bond_law({"law": "harmonic", **parameters}, kT=1.0)
    fraenkel = bonds.bond_law({"law": "fraenkel", **parameters}, kT=1.0)
    q_sq = jnp.linspace(0.1, 2.0, 7)
    assert harmonic.name == "harmonic"
    np.testing.assert_array_equal(harmonic.stiffness(q_sq), fraenkel.stiffness(q_sq))
    np.testing.assert_allclose(harmonic.energy(jnp.asarray([1.0])), 0.5 * 30.0 * 0.2**2)


class _Quartic(bonds.BondLaw):
    """A toy law U = ¼ c Q⁴ (T/Q = c Q²), defined here to show that a new bond law is
    one class plus one registry line."""

    name = "quartic"
    parameters = {"c": bonds.Parameter(2.0)}

    def stiffness(self, q_sq, c):
        return c * q_sq

    def energy(self, q_sq, c):
        return 0.25 * c * q_sq * q_sq

    def placement_length(self, values, kT):
        return 1.0


def test_a_registered_law_is_read_from_a_bond_table_and_drives_the_springs():
    """A law registered from outside the package is known to the scene reader (with its
    defaults and its own parameter names) and its forces are −∇U."""
    bonds.BOND_LAWS.register(_Quartic())
    try:
        assert bonds.read_bond({"law": "quartic"}, "polymers[0].bond") == {
            "law": "quartic",
            "c": 2.0,
        }
        with pytest.raises(ValueError, match=r"\['spring_constant'\] are not parameters"):
            bonds.read_bond({"law": "quartic", "spring_constant": 1.0}, "polymers[0].bond")
        law = bonds.bond_law({"law": "quartic", "c": 3.0}, kT=1.0)
        positions, image, unwrapped = _chains(2)

        def energy(unwrapped_positions):
            springs = unwrapped_positions[:, 1:] - unwrapped_positions[:, :-1]
            return jnp.sum(law.energy(jnp.sum(springs**2, axis=-1)))

        result = bonds.chain_bond_forces(BOX, positions, image, law, with_virial=False)
        expected = -jax.grad(energy)(jnp.asarray(unwrapped))
        np.testing.assert_allclose(result.forces, expected, rtol=1e-10, atol=1e-12)
    finally:
        bonds.BOND_LAWS.unregister("quartic")
    with pytest.raises(ValueError, match="polymers\\[0\\].bond.law = 'quartic': valid values"):
        bonds.read_bond({"law": "quartic"}, "polymers[0].bond")


def test_brownian_springs_are_the_bond_laws_with_unit_spring_constant():
    """The dumbbell force factor f(Q²) of jaxdpd.brownian.springs is the DPD law's T/Q
    with H = 1, Q0 = √b (one definition of each law)."""
    from jaxdpd.brownian import FENE, Hookean

    q_sq = jnp.linspace(0.0, 40.0, 9)
    fene = bonds.bond_law({"law": "fene", "spring_constant": 1.0, "max_extension": 50**0.5}, 1.0)
    np.testing.assert_array_equal(FENE(50.0).force_factor(q_sq), fene.stiffness(q_sq))
    np.testing.assert_allclose(FENE(50.0).force_factor(q_sq), 1 / (1 - q_sq / 50), rtol=1e-14)
    np.testing.assert_array_equal(Hookean().force_factor(q_sq), jnp.ones_like(q_sq))
    np.testing.assert_array_equal(Hookean().potential(q_sq), 0.5 * q_sq)
