"""Forces, virial pressure and g(r) against independent brute-force calculations."""

import jax.numpy as jnp
import numpy as np
import pytest
from conftest import make_scene

from jaxdpd.engine import noise
from jaxdpd.engine.build import build
from jaxdpd.geometry.boxes import make_box
from jaxdpd.io.layout import reduced_unit
from jaxdpd.observables import OBSERVABLES, reduce_samples
from jaxdpd.observables.component import Observable, Setting
from jaxdpd.observables.rdf import RadialDistribution
from jaxdpd.run.runner import simulate
from jaxdpd.validation import SceneError


def brute_force_dpd(positions, velocities, lengths, a, gamma, kT, dt, seed, step):
    """Groot–Warren forces and the virial of each force law over all pairs i < j
    (thesis eqs. 2.4–2.9, 3.46),
    written independently of jaxdpd's kernels (only the noise hash is shared: it is
    the definition of θ_ij)."""
    n = len(positions)
    i, j = np.triu_indices(n, 1)
    d = positions[i] - positions[j]
    d -= lengths * np.round(d / lengths)
    r = np.linalg.norm(d, axis=1)
    keep = r < 1.0
    i, j, d, r = i[keep], j[keep], d[keep], r[keep]
    e = d / r[:, None]
    w = 1 - r
    theta = np.asarray(
        noise.pair_uniform_unit_variance(
            noise.step_key(seed, step), jnp.asarray(i), jnp.asarray(j), jnp.float64
        )
    )
    sigma = np.sqrt(2 * gamma * kT)
    normal_velocity = np.sum(e * (velocities[i] - velocities[j]), axis=1)
    parts = {
        "conservative": a * w,
        "dissipative": -gamma * w * w * normal_velocity,
        "random": sigma * w * theta / np.sqrt(dt),
    }
    pair_force = sum(parts.values())[:, None] * e
    forces = np.zeros_like(positions)
    np.add.at(forces, i, pair_force)
    np.subtract.at(forces, j, pair_force)
    virial = {name: d.T @ (m[:, None] * e) for name, m in parts.items()}
    return forces, virial


def test_forces_and_virial_match_brute_force():
    scene = make_scene()
    simulation = build(scene)
    state = simulation.init_fn()  # forces and virial at step 0
    forces, virial = brute_force_dpd(
        np.asarray(state.positions),
        np.asarray(state.velocities),
        np.asarray(scene.box.lengths),
        25.0,
        4.5,
        1.0,
        0.04,
        scene.seed,
        0,
    )
    np.testing.assert_allclose(state.forces, forces, atol=1e-10)
    assert set(state.virial) == set(virial)
    for name, part in virial.items():
        np.testing.assert_allclose(state.virial[name], part, atol=1e-8, err_msg=name)


def test_species_matrix_selects_a_ij():
    """Two species with a_AA = 25, a_BB = 40, a_AB = 30 and γ = 0: forces equal the
    brute-force sum with each pair's own a_ij."""
    scene = make_scene(
        particles={
            "count": 600,
            "density": 3.0,
            "species": [{"name": "A", "fraction": 0.5}, {"name": "B", "fraction": 0.5}],
        },
        pair={"a": {"A-A": 25.0, "B-B": 40.0, "A-B": 30.0}},
        solvent={"gamma": 0.0},
    )
    state = build(scene).init_fn()
    positions = np.asarray(state.positions)
    species = np.asarray(state.species)
    lengths = np.asarray(scene.box.lengths)
    table = np.array([[25.0, 30.0], [30.0, 40.0]])
    i, j = np.triu_indices(len(positions), 1)
    d = positions[i] - positions[j]
    d -= lengths * np.round(d / lengths)
    r = np.linalg.norm(d, axis=1)
    w = np.clip(1 - r, 0, None)
    pair_force = (table[species[i], species[j]] * w / np.where(r > 0, r, 1))[:, None] * d
    forces = np.zeros_like(positions)
    np.add.at(forces, i, pair_force)
    np.subtract.at(forces, j, pair_force)
    np.testing.assert_allclose(state.forces, forces, atol=1e-10)


def test_ideal_gas_rdf_is_one_and_pressure_is_rho_kT():
    """No pair term: free flight, g(r) = 1 (each shell's pair count is ≈ Poisson,
    tolerance 5 σ) and P = ρ k_BT exactly (only the kinetic part)."""
    scene = make_scene(
        pair=None,
        solvent={"gamma": 0.0},
        run={"steps": 500, "chunk": 50},
        output={"observables": ["temperature", "pressure", "rdf"], "rdf_max": 2.5, "rdf_bins": 25},
    )
    summary = simulate(scene, progress=False, keep_series=True)
    r, g = summary.rdf
    n = scene.n_particles
    edges = np.linspace(0, 2.5, 26)
    expected = 0.5 * n * (n - 1) * 4 / 3 * np.pi * np.diff(edges**3) / scene.volume * 10
    assert np.all(np.abs(g - 1) < 5 / np.sqrt(expected))
    np.testing.assert_allclose(
        summary.series["pressure"],
        scene.particles.density * summary.series["temperature"] * (n - 1) / n,
        rtol=1e-12,
    )


@pytest.mark.parametrize("r_max, searched_by", [(1.4, "cell list"), (2.0, "all pairs")])
def test_rdf_counts_equal_a_brute_force_histogram(r_max, searched_by):
    """The pair histogram of g(r) equals NumPy's of all minimum-image distances in a
    6 r_c box, with pairs found by the cell list (4 cells per axis) or, where no axis
    has more than three cells, from the list of all pairs."""
    n, bins, lengths = 500, 28, (6.0, 6.0, 6.0)
    box = make_box("periodic", lengths)
    positions = np.random.default_rng(3).uniform(size=(n, 3)) * np.asarray(lengths)
    rdf = RadialDistribution(box, n, r_max, bins)
    assert rdf._all_pairs == (searched_by == "all pairs")
    rdf.sample(jnp.asarray(positions))
    i, j = np.triu_indices(n, 1)
    d = positions[i] - positions[j]
    d -= np.asarray(lengths) * np.round(d / np.asarray(lengths))
    expected, _ = np.histogram(np.linalg.norm(d, axis=1), bins=bins, range=(0.0, r_max))
    np.testing.assert_array_equal(rdf.counts, expected)


class ToyMomentum(Observable):
    """A toy observable: the scaled total momentum, with one [output] setting."""

    name = "toy_momentum"
    settings = (Setting("toy_scale", 2.0, minimum=0),)
    units = {"toy_momentum": "r_c/τ"}

    def sampler(self, context):
        scale = context.scene.output.toy_scale

        def sample(previous, state):
            return state, {"toy_momentum": scale * state.velocities.sum(axis=0)}

        return sample


@pytest.mark.slow  # tests/test_toy_components.py registers one in the default run
def test_a_toy_observable_is_one_class_and_one_register_line():
    """Registering an observable gives it its [output] setting, its sample in the step
    (after the built-in ones, which are unchanged), its series and its unit."""
    OBSERVABLES.register(ToyMomentum())
    try:
        scene = make_scene(output={"observables": ["temperature", "toy_momentum"], "toy_scale": 3})
        assert scene.output.toy_scale == 3
        assert scene.to_dict()["output"]["toy_scale"] == 3
        simulation = build(scene)
        state = simulation.init_fn()
        _, samples = simulation.step_fn(state)
        assert set(samples) == {"kinetic", "toy_momentum"}
        series = reduce_samples({name: value[None] for name, value in samples.items()}, scene)
        assert list(series) == ["toy_momentum", "temperature"]
        assert reduced_unit("observables/toy_momentum") == "r_c/τ"
    finally:
        OBSERVABLES.unregister("toy_momentum")
    with pytest.raises(SceneError, match="output.observables: 'toy_momentum'"):
        make_scene(output={"observables": ["toy_momentum"]})


def test_every_observable_names_its_needs():
    """An observable that measures polymers is refused without them, naming the field."""
    for component in OBSERVABLES:
        if component.needs_polymers:
            with pytest.raises(SceneError, match=f"output.observables: '{component.name}'"):
                make_scene(output={"observables": [component.name]})
