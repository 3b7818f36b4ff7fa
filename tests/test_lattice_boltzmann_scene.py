"""Scene fields of the lattice-Boltzmann solvent and the WCA pair kind: validation,
round trip, and the WCA force law."""

import copy
import math

import jax
import jax.numpy as jnp
import numpy as np
import pytest
from lattice_boltzmann_scenes import LB_CHAIN, lb_chain_scene

from jaxdpd.forces.pair_laws import WCA_RANGE_FACTOR, wca_energy, wca_force_over_distance, wca_term
from jaxdpd.forces.pair_sums import accumulate, pair_geometry
from jaxdpd.geometry.boxes import PeriodicBox
from jaxdpd.geometry.chain_topology import chain_blocks
from jaxdpd.geometry.neighbors import PairList, neighbor_search
from jaxdpd.geometry.placement import initial_configuration
from jaxdpd.observables.thermo import temperature
from jaxdpd.scene import Scene
from jaxdpd.solvents.lattice_boltzmann import fluid_parameters, md_steps_per_lattice_step

LATTICE_SCENE = lb_chain_scene(
    precision="float64",
    box={"lengths": [6.0, 6.0, 9.0]},
    particles={"count": 20, "species": [{"name": "M"}]},
    polymers=[{**LB_CHAIN["polymers"][0], "species": "M", "beads": 10}],
    neighbors=None,
    run=None,
    output=None,
)
LATTICE_SCENE["solvent"].update(grid_spacing=1.5, friction=20.8)


SOLVENT_KEYS = {*LATTICE_SCENE["solvent"], "kinematic_bulk_viscosity", "noise", "gamma"}


def lattice_scene(**changes) -> dict:
    """LATTICE_SCENE with whole sections or solvent fields changed (None removes)."""
    data = copy.deepcopy(LATTICE_SCENE)
    for key, value in changes.items():
        target = data["solvent"] if key in SOLVENT_KEYS else data
        if value is None:
            target.pop(key, None)
        else:
            target[key] = value
    return data


INVALID = [
    ({"grid_spacing": None}, ValueError, ["solvent.grid_spacing", "required"]),
    ({"grid_spacing": 0.0}, ValueError, ["solvent.grid_spacing", "> 0"]),
    ({"grid_spacing": 1.25}, ValueError, ["box.lengths", "grid_spacing", "L_x"]),
    ({"time_step": 0.055}, ValueError, ["solvent.time_step", "integrator.dt", "whole"]),
    ({"kinematic_viscosity": -1.0}, ValueError, ["solvent.kinematic_viscosity", "> 0"]),
    ({"kinematic_bulk_viscosity": 0.0}, ValueError, ["kinematic_bulk_viscosity", "> 0"]),
    ({"mass_density": "1"}, TypeError, ["solvent.mass_density", "number"]),
    ({"friction": 0.0}, ValueError, ["solvent.friction", "> 0"]),
    ({"kT": -1.0}, ValueError, ["solvent.kT", "≥ 0"]),
    ({"noise": "pink"}, ValueError, ["solvent.noise", "uniform"]),
    ({"gamma": 4.5}, ValueError, ["gamma", "lattice_boltzmann"]),
    ({"kT": 500.0}, ValueError, ["Mach", "time_step"]),
    ({"integrator": {"dt": 0.01, "lambda": 0.65}}, ValueError, ["integrator.lambda"]),
    ({"output": {"observables": ["pressure"]}}, ValueError, ["pressure", "fluid"]),
    ({"pair": {"kind": "wca", "epsilon": 1.0}}, ValueError, ["pair.sigma", "required"]),
    ({"pair": {"kind": "wca", "sigma": 1.0, "epsilon": 1.0, "a": 25}}, ValueError, ["pair.a"]),
    ({"pair": {"kind": "wca", "sigma": 0.0, "epsilon": 1.0}}, ValueError, ["pair.sigma", "> 0"]),
    ({"pair": {"kind": "soft_repulsion", "a": 25, "sigma": 1.0}}, ValueError, ["sigma", "wca"]),
    ({"cutoff": 1.0}, ValueError, ["cutoff", "2^(1/6)"]),
]


@pytest.mark.parametrize(("changes", "error", "words"), INVALID)
def test_invalid_lattice_boltzmann_fields_are_named(changes, error, words):
    with pytest.raises(error) as caught:
        Scene.from_dict(lattice_scene(**changes))
    message = str(caught.value)
    for word in words:
        assert word in message, (word, message)


def test_lattice_fields_are_refused_by_particle_solvents():
    data = {
        "particles": {"density": 3.0, "count": 600},
        "solvent": {"method": "dpd", "grid_spacing": 1.0},
    }
    with pytest.raises(ValueError, match="belong to method 'lattice_boltzmann'"):
        Scene.from_dict(data)


def test_lattice_scene_resolves_defaults_and_round_trips():
    data = lattice_scene(integrator=None, time_step=0.05)
    scene = Scene.from_dict(data)
    assert scene.integrator.dt == 0.05  # default: one MD step per LB step
    assert scene.solvent.kinematic_bulk_viscosity == 2.8  # default: the shear value
    assert scene.solvent.noise == "uniform"
    assert scene.output.observables == ("temperature",)
    assert math.isclose(scene.cutoff, WCA_RANGE_FACTOR)
    assert Scene.from_dict(scene.to_dict()) == scene
    scene = Scene.from_dict(lattice_scene())
    assert md_steps_per_lattice_step(scene) == 5
    fluid = fluid_parameters(scene)
    assert fluid.nodes == (4, 4, 6)
    assert not scene.particle_momentum_conserved
    assert Scene.from_dict(scene.to_dict()) == scene


def test_wca_law_is_minus_the_derivative_of_its_energy_and_vanishes_at_its_range():
    """WCA (Weeks, Chandler & Andersen 1971; seed eq. 8): F = −dU/dr by central
    differences (step 1e-6, error O(1e-12) relative), U and F zero at and beyond
    r = 2^(1/6) σ, U(r → 2^(1/6)σ) → 0 continuously."""
    epsilon, sigma = 1.3, 0.9
    energy = jax.jit(lambda q_sq: wca_energy(q_sq, epsilon, sigma))
    r = np.linspace(0.8, 1.3, 101) * sigma
    h = 1e-6
    derivative = (np.asarray(energy((r + h) ** 2)) - np.asarray(energy((r - h) ** 2))) / (2 * h)
    force = r * np.asarray(jax.jit(wca_force_over_distance)(r**2, epsilon, sigma))
    inside = r < WCA_RANGE_FACTOR * sigma - 2 * h
    np.testing.assert_allclose(force[inside], -derivative[inside], rtol=1e-6)
    outside = r >= WCA_RANGE_FACTOR * sigma
    assert np.all(force[outside] == 0) and np.all(np.asarray(energy(r[outside] ** 2)) == 0)
    edge = (WCA_RANGE_FACTOR * sigma * (1 - 1e-9)) ** 2
    assert abs(float(energy(np.array([edge]))[0])) < 1e-7 * epsilon
    assert float(energy(np.array([sigma**2]))[0]) == pytest.approx(epsilon)


def test_wca_pair_term_matches_brute_force_forces():
    """The pair term on a list of all pairs gives the forces of a brute-force sum of
    −∇U over minimum images; they sum to zero (Newton's third law)."""
    box = PeriodicBox((4.0, 4.0, 4.0))
    rng = np.random.default_rng(3)
    positions = rng.random((12, 3)) * 4.0
    positions[1] = positions[0] + [0.95, 0.1, 0.0]  # make sure some pairs interact
    cutoff = WCA_RANGE_FACTOR
    i, j = np.triu_indices(12, 1)
    zero = jnp.asarray(0, jnp.int32)
    pairs = PairList(
        jnp.asarray(i, jnp.int32),
        jnp.asarray(j, jnp.int32),
        jnp.asarray(positions),
        None,
        zero,
        zero,
        jnp.asarray(False),
        zero,
    )
    term = wca_term(1.0, 1.0, jnp.float64)

    @jax.jit
    def pair_forces(positions):
        geometry = pair_geometry(box, positions, pairs, cutoff, True)
        return accumulate(geometry, term(geometry, None)["conservative"])

    forces = pair_forces(jnp.asarray(positions))
    expected = np.zeros((12, 3))
    for a, b in zip(i, j, strict=True):
        d = positions[a] - positions[b]
        d -= 4.0 * np.round(d / 4.0)
        distance = np.sqrt(d @ d)
        if distance < cutoff:  # −dU/dr along d, U = 4[(1/r)¹² − (1/r)⁶ + ¼]
            f = d / distance * 24 * (2 / distance**13 - 1 / distance**7)
        else:
            f = np.zeros(3)
        expected[a] += f
        expected[b] -= f
    largest = np.abs(expected).max()
    assert largest > 1.0
    np.testing.assert_allclose(np.asarray(forces), expected, rtol=1e-12, atol=1e-14 * largest)
    np.testing.assert_allclose(np.asarray(forces).sum(axis=0), 0, atol=1e-14 * largest)


def test_wca_chains_start_without_overlaps_and_all_pairs_lists_every_pair():
    """With a WCA pair the placement grows chains as self-avoiding walks: no two
    non-bonded beads closer than σ (minimum image), bonds at the FENE–WCA minimum;
    the all_pairs neighbour list holds each of the N(N−1)/2 pairs once."""
    scene = Scene.from_dict(
        lattice_scene(
            particles={"count": 60, "species": [{"name": "M"}]},
            neighbors={"method": "all_pairs"},
        )
    )
    box = PeriodicBox(scene.box.lengths)
    blocks = chain_blocks(scene)
    positions, _, _, _ = initial_configuration(scene, box, jnp.float64, blocks)
    positions = np.asarray(positions)
    lengths = np.asarray(scene.box.lengths)
    separation = positions[:, None] - positions[None]
    separation -= lengths * np.round(separation / lengths)
    distance = np.linalg.norm(separation, axis=-1)
    bonded = np.zeros_like(distance, bool)
    for chain in range(6):
        k = chain * 10 + np.arange(9)
        bonded[k, k + 1] = bonded[k + 1, k] = True
    others = ~bonded & ~np.eye(60, dtype=bool)
    assert distance[others].min() >= 1.0 - 1e-6
    bond_length = blocks[0].law.placement_length  # 1.042 for k = 7, R0 = 2
    np.testing.assert_allclose(distance[bonded], bond_length, rtol=1e-6)
    search = neighbor_search(box, 60, scene.cutoff, 0.0, "all_pairs")
    pairs = search.allocate(jnp.asarray(positions))
    assert pairs.capacity == 60 * 59 // 2
    assert len({(int(i), int(j)) for i, j in zip(pairs.i, pairs.j, strict=True)}) == 1770
    with pytest.raises(ValueError, match="neighbors.skin"):
        Scene.from_dict(lattice_scene(neighbors={"method": "all_pairs", "skin": 0.3}))


def test_bead_temperature_counts_3n_degrees_of_freedom():
    """Beads exchange momentum with the fluid, so their total momentum is not fixed:
    the kinetic temperature of N beads is Σ m v²/(3N), not /(3N − 3)."""
    kinetic = np.eye(3)[None] * np.array([4.0])[:, None, None]  # tr = 12
    particles = temperature(kinetic, 2, momentum_conserved=True)
    beads = temperature(kinetic, 2, momentum_conserved=False)
    assert particles[0] == pytest.approx(4.0) and beads[0] == pytest.approx(2.0)
