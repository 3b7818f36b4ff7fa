"""MPCD (SRD) in planar elongation: collision cells in the lattice coordinates of the
Kraynik–Reinelt box (jaxdpd.solvents.mpcd.lattice_cells; docs/solvent_flows/mpcd.md).

References:
- an ideal gas (uniform points, Poisson statistics) fills every cell of a tiling of
  equal-volume cells alike: N points over K cells are multinomial with p = 1/K, so
  Σ (n_c − N/K)²/(N/K) is χ² with K − 1 degrees of freedom, at every strain of the
  period and for cells at the faces as in the interior;
- a collision cell is a contiguous piece of the periodic fluid: its members, taken at
  the minimum image of one of them (the box's minimum image, tested against brute
  force in tests/test_kraynik_reinelt_geometry.py), have laboratory velocities
  c + L r, and the collision sees exactly these relative to the cell mean;
- SRD conserves each cell's momentum and (without a thermostat) its kinetic energy
  in the laboratory frame (Mussawisade et al., J. Chem. Phys. 123, 144905 (2005));
  SLLOD streaming keeps Σ m c = 0 (thesis eqs. 3.42–3.43).
The statistical checks (Trouton ratio, 200 periods) are in
tests/test_mpcd_elongation_slow.py.
"""

import math

import jax
import jax.numpy as jnp
import numpy as np
import pytest
from lattice_boltzmann_scenes import lb_chain_scene
from mpcd_scenes import polymer_solution, pure_solvent

from jaxdpd.engine import noise
from jaxdpd.engine.build import build
from jaxdpd.geometry.boxes import KraynikReineltBox
from jaxdpd.run import driver
from jaxdpd.scene import Scene
from jaxdpd.solvents.mpcd.cells import collision_grid, grid_shift
from jaxdpd.solvents.mpcd.collision import srd_collision
from jaxdpd.solvents.mpcd.lattice_cells import bin_in_lattice

LENGTHS = (6.0, 4.0, 6.0)
GRID = collision_grid(LENGTHS, 1.0)
FLOW = {"kind": "planar_elongation", "elongation_rate": 0.5}
SCENE_FILE = """
seed = 4
precision = "float32"
[box]
lengths = [4.0, 3.0, 4.0]
[particles]
density = 5.0
[solvent]
method = "mpcd"
collision_time = 0.1
thermostat = "maxwell_boltzmann_scaling"
[flow]
kind = "planar_elongation"
elongation_rate = 0.5
[output]
observables = ["temperature", "pressure"]
"""


def box_state(box, strain, rate=0.5):
    return box.initial_state(jnp.float64).set(
        strain=jnp.asarray(strain, jnp.float64), elongation_rate=jnp.asarray(rate, jnp.float64)
    )


def strains_over_the_period(box):
    """Strains across one period, both sides of every change of reduced basis and of
    the reset."""
    switches = np.asarray(box.geometry.switch_strains)
    edges = np.concatenate([switches - 1e-9, switches + 1e-9])
    half = box.period / 2
    return [*np.linspace(-half, half, 7)[:-1], -half, half - 1e-9, *edges]


def uniform_gas(box, bound, fractions, images):
    """Points uniform modulo the lattice, wrapped into the primary cell by the box:
    fractional coordinates (n, 3) in [0, 1) of the primary cell, moved by whole
    lattice vectors `images` (n, 3)."""
    points = jnp.asarray(box.centre) + (fractions + images - 0.5) @ bound.lattice_vectors.T
    positions, _ = bound.wrap(points, jnp.zeros(points.shape, jnp.int32))
    return positions


def test_mpcd_planar_elongation_runs_from_a_scene_file(tmp_path):
    """A TOML scene: 50 collisions at ε̇ = 0.5 without an error flag; the box strain
    is ε̇ t modulo the Kraynik–Reinelt period."""
    path = tmp_path / "mpcd_elongation.toml"
    path.write_text(SCENE_FILE)
    scene = Scene.from_toml(path)
    assert scene.box.kind == "kraynik_reinelt" and scene.solvent.method == "mpcd"
    simulation = build(scene)
    state, _, _ = driver.run_chunk(simulation, simulation.init_fn(), 50)
    assert int(state.flags) == 0
    period = simulation.box.period
    strain = (0.5 * 5.0 + period / 2) % period - period / 2
    assert abs(float(state.box_state.strain) - strain) < 1e-5


def test_polymer_solution_in_elongation_keeps_zero_peculiar_momentum():
    """Chains (monomer sub-steps with SLLOD) in an SRD solvent at ε̇ = 0.2 in a 6³
    box, float64, built from Python: after 30 collisions Σ m c is 0 to round-off, no flag is set and
    the virial has its bond, collision and free-flight parts."""
    data = polymer_solution(
        flow={**FLOW, "elongation_rate": 0.2},
        output={"observables": ["temperature", "pressure"]},
    )
    simulation = build(Scene.from_dict(data))
    masses = np.asarray(simulation.masses)
    state, samples, _ = driver.run_chunk(simulation, simulation.init_fn(), 30)
    velocities = np.asarray(state.velocities)
    assert int(state.flags) == 0
    np.testing.assert_allclose(
        masses @ velocities, 0, atol=1e-12 * (masses @ np.abs(velocities)).max()
    )
    assert set(samples["virial"]) == {"bond", "collision", "streaming"}


@pytest.mark.parametrize(
    "data, fields",
    [
        (
            lb_chain_scene(flow=FLOW),
            ["flow.kind = 'planar_elongation'", "solvent.method = 'lattice_boltzmann'"],
        ),
        (
            pure_solvent(5.0, 130.0, 0.1, 6, box={"lengths": [6.3, 4.0, 6.3]}, flow=FLOW),
            ["box.lengths", "solvent.cell_size"],
        ),
    ],
)
def test_unsupported_elongation_scenes_name_the_fields(data, fields):
    """Lattice Boltzmann has no Kraynik–Reinelt step; MPCD cells must tile the frame."""
    with pytest.raises(ValueError) as error:
        Scene.from_dict(data)
    for field in fields:
        assert field in str(error.value), (field, str(error.value))


def test_lattice_cells_hold_an_ideal_gas_evenly_at_every_strain():
    """N = 1440 uniform points (ρ = 10 per cell) binned with a random shift, 40 draws
    at each of 12 strains (both sides of every basis change and of the reset): the
    pooled χ² of the cell counts is within 4 standard deviations of its mean, and the
    cells on the faces of the primary cell hold ρ within 4 standard errors — no
    depletion or crowding (a Cartesian grid clipped at the faces fails both)."""
    box = KraynikReineltBox(LENGTHS, 0.5)
    rng = np.random.default_rng(11)
    n, draws = 1440, 40
    shape = np.asarray(GRID.shape)
    expected = n / GRID.n_cells

    @jax.jit
    def cells(strain, fractions, images, shift):
        bound = box.bind(box_state(box, strain))
        positions = uniform_gas(box, bound, fractions, images)
        return bin_in_lattice(GRID, bound, positions, jnp.zeros_like(positions), shift).cell

    chi_squared, dof, face_counts = 0.0, 0, []
    index = np.stack(np.unravel_index(np.arange(GRID.n_cells), shape, order="F"), axis=1)
    on_face = np.any((index[:, [0, 2]] == 0) | (index[:, [0, 2]] == shape[[0, 2]] - 1), axis=1)
    for strain in strains_over_the_period(box):
        for _ in range(draws):
            fractions, images = rng.uniform(size=(n, 3)), rng.integers(-2, 3, size=(n, 3))
            shift = rng.uniform(size=3) * GRID.cell_size
            counts = np.bincount(
                np.asarray(cells(strain, fractions, images, shift)), minlength=GRID.n_cells
            )
            assert counts.sum() == n and len(counts) == GRID.n_cells
            chi_squared += np.sum((counts - expected) ** 2) / expected
            dof += GRID.n_cells - 1
            face_counts.append(counts[on_face].mean())
    assert abs(chi_squared - dof) < 4 * math.sqrt(2 * dof), (chi_squared, dof)
    samples = len(face_counts)
    error = math.sqrt(expected * (1 - 1 / GRID.n_cells) / on_face.sum() / samples)
    assert abs(np.mean(face_counts) - expected) < 4 * error, (np.mean(face_counts), error)


@pytest.mark.parametrize("strain", [0.37, -0.48])
def test_cells_are_contiguous_and_see_laboratory_velocities(strain):
    """At ε̇ = 0.5, float64: every member of a cell lies in the cell's parallelepiped
    (Cartesian offset ξ = (lattice/n) f with f ∈ [0, 1)³) with one corner per cell
    (corners agree to 1e-10 modulo the lattice); relative to the cell mean the
    collision sees the laboratory velocities c + L r of the members taken at the
    minimum image of one of them (to 1e-10).  The SRD collision then conserves every
    cell's momentum (Σ Δc = 0 to 1e-12 of Σ|c|) and its laboratory-frame kinetic
    energy (to 1e-12 relative)."""
    box = KraynikReineltBox(LENGTHS, 0.5)
    rng = np.random.default_rng(5)
    n = 1440
    bound = box.bind(box_state(box, strain))
    positions = uniform_gas(box, bound, rng.uniform(size=(n, 3)), rng.integers(-2, 3, size=(n, 3)))
    velocities = jnp.asarray(rng.normal(size=(n, 3)))
    key = noise.step_key(jnp.uint32(3), 1)
    shift = grid_shift(key, GRID.cell_size, jnp.float64)  # the collision's own shift
    binned = jax.jit(lambda r, v: bin_in_lattice(GRID, bound, r, v, shift))(positions, velocities)
    cell, local = np.asarray(binned.cell), np.asarray(binned.local)
    edges = np.asarray(bound.lattice_vectors) / np.asarray(GRID.shape)
    fractions = np.linalg.solve(edges, local.T).T
    assert np.all((fractions > -1e-10) & (fractions < 1 + 1e-10))
    _, first = np.unique(cell, return_index=True)
    leader = first[np.searchsorted(cell[first], cell)]
    r = np.asarray(positions)
    corners = jnp.asarray((r - local) - (r - local)[leader])
    np.testing.assert_allclose(np.asarray(bound.minimum_image_vectors(corners)), 0, atol=1e-10)
    unwrapped = r[leader] + np.asarray(bound.minimum_image_vectors(jnp.asarray(r - r[leader])))
    gradient = np.asarray(bound.velocity_gradient)
    laboratory = np.asarray(velocities) + unwrapped @ gradient.T
    seen = np.asarray(binned.frame_velocities)

    def relative(v):
        sums = np.stack([np.bincount(cell, v[:, k], GRID.n_cells) for k in range(3)], axis=1)
        counts = np.bincount(cell, minlength=GRID.n_cells)
        return v - (sums / np.maximum(counts, 1)[:, None])[cell]

    np.testing.assert_allclose(relative(seen), relative(laboratory), atol=1e-10)
    collide = srd_collision(
        GRID, math.radians(130), None, None, False, jnp.float64, binning=bin_in_lattice
    )
    after, _ = jax.jit(lambda r, v: collide(bound, r, v, key))(positions, velocities)
    change = np.asarray(after) - np.asarray(velocities)
    momentum = np.stack([np.bincount(cell, change[:, k], GRID.n_cells) for k in range(3)])
    assert np.abs(momentum).max() < 1e-12 * np.abs(np.asarray(velocities)).sum()
    energy = np.bincount(cell, np.sum(seen**2, axis=1), GRID.n_cells)
    energy_after = np.bincount(cell, np.sum((seen + change) ** 2, axis=1), GRID.n_cells)
    np.testing.assert_allclose(energy_after, energy, rtol=1e-12)
