"""Spring–spring repulsion in scenes: validation, composition, and the reduction of
spring crossings in a semidilute chain solution (thesis §5.2–5.3)."""

import math

import h5py
import numpy as np
import pytest
from conftest import make_scene, scene_dict

from jaxdpd.engine.build import build
from jaxdpd.geometry.chain_topology import chain_blocks
from jaxdpd.run import ensemble
from jaxdpd.run.driver import run_chunk
from jaxdpd.run.runner import resume, simulate
from jaxdpd.scene import Scene

FENE = {"law": "fene", "spring_constant": 8.0, "max_extension": 2.5}
CHAINS = {
    "particles": {
        "density": 3.0,
        "count": 600,
        "species": [{"name": "P", "count": 200}, {"name": "S", "count": 400}],
    },
    "polymers": [{"species": "P", "beads": 20, "bond": FENE}],
}

INVALID = [
    ({"spring_repulsion": {"law": "quadratic"}}, ValueError, ["spring_repulsion.law", "linear"]),
    ({"spring_repulsion": {"law": "linear"}}, ValueError, ["spring_repulsion", "a"]),
    ({"spring_repulsion": {"law": "linear", "a": 25, "A": 3}}, ValueError, ["'A'", "linear"]),
    ({"spring_repulsion": {"alpha": -1.0}}, ValueError, ["spring_repulsion.alpha", "> 0"]),
    ({"spring_repulsion": {"range": 0}}, ValueError, ["spring_repulsion.range", "> 0"]),
    (
        {"spring_repulsion": {"range": 0.1, "distance_floor": 0.2}},
        ValueError,
        ["distance_floor", "0.2", "range"],
    ),
    ({"spring_repulsion": {"range": 2.9}}, ValueError, ["spring_repulsion.range", "half"]),
    ({"spring_repulsion": {"strength": 1}}, ValueError, ["spring_repulsion", "strength"]),
    ({"neighbors": {"spring_skin": -1}}, ValueError, ["neighbors.spring_skin", "≥ 0"]),
    (
        {"output": {"observables": ["spring_pairs"], "spring_pair_max": 0}},
        ValueError,
        ["output.spring_pair_max", "> 0"],
    ),
]


@pytest.mark.parametrize(("changes", "error", "words"), INVALID)
def test_invalid_spring_repulsion_fields_are_named(changes, error, words):
    with pytest.raises(error) as raised:
        make_scene(**CHAINS, **changes)
    for word in words:
        assert word in str(raised.value)


def test_spring_repulsion_needs_chains():
    with pytest.raises(ValueError, match=r"spring_repulsion.*polymers"):
        make_scene(spring_repulsion={"law": "exponential"})
    with pytest.raises(ValueError, match=r"spring_pairs"):
        make_scene(output={"observables": ["spring_pairs"]})


def test_defaults_are_the_thesis_values_and_round_trip():
    """Kumar–Larson A = 100, α = 10 over r_c/3 with the 0.001 r_c floor (thesis
    §5.2.2); to_dict/from_dict reproduces the section."""
    scene = make_scene(**CHAINS, spring_repulsion={})
    assert scene.spring_repulsion.table() == {
        "law": "exponential",
        "A": 100.0,
        "alpha": 10.0,
        "range": pytest.approx(1 / 3),
        "distance_floor": pytest.approx(1e-3),
    }
    assert type(scene).from_dict(scene.to_dict()) == scene


def test_nothing_of_springs_is_built_unless_asked():
    """Without [spring_repulsion] or the "spring_pairs" observable there is no
    spring-pair list (simulate only what the scene calls for)."""
    assert build(make_scene(**CHAINS)).spring_search is None
    assert build(make_scene(**CHAINS, spring_repulsion={})).spring_search is not None


def crossing_scene(repulsion):
    """A θ-solvent solution of 20-bead FENE chains (H = 3, Q0 = 3, b = 27) at
    c/c* ≈ 2 (see `overlap_ratio`), DPD at ρ = 3, a = 25, in a 7³ box."""
    data = scene_dict(
        box={"lengths": [7.0, 7.0, 7.0]},
        particles={"species": [{"name": "P", "count": 700}, {"name": "S", "count": 329}]},
        polymers=[
            {
                "species": "P",
                "beads": 20,
                "bond": {**FENE, "spring_constant": 3.0, "max_extension": 3.0},
            }
        ],
        spring_repulsion=repulsion,
        neighbors={"spring_skin": 0.2},
        output={"observables": ["temperature", "pressure", "spring_pairs"]},
        integrator={"dt": 0.005},
    )
    data["particles"] = {"count": 1029, "species": data["particles"]["species"]}
    return Scene.from_dict(data)


def overlap_ratio(scene) -> float:
    """c/c* = (4/3) π n R_G³ / V (thesis eq. 5.10) with the ideal (Rouse) coil size
    R_G² = (N² − 1)/(6N) ⟨Q²⟩ of N-bead chains whose springs have the placement
    length ⟨Q²⟩^{1/2} (the FENE equilibrium value, thesis eq. 4.8)."""
    (block,) = chain_blocks(scene)
    beads = block.beads
    radius_of_gyration = math.sqrt((beads**2 - 1) / (6 * beads)) * block.law.placement_length
    return 4 / 3 * math.pi * block.n_chains * radius_of_gyration**3 / scene.volume


def count_crossings(scene, steps: int, chunk: int):
    simulation = build(scene)
    state = simulation.init_fn()
    crossings = 0.0
    histogram = 0.0
    for _ in range(steps // chunk):
        state, samples, _ = run_chunk(simulation, state, chunk)
        crossings += float(np.sum(samples["spring_pairs/crossings"]))
        histogram = histogram + np.sum(samples["spring_pairs/histogram"], axis=0)
    return crossings, histogram, state


@pytest.mark.slow
def test_exponential_repulsion_cuts_spring_crossings_tenfold():
    """Spring crossings (closest-approach vector reversing within both springs in one
    step) fall at least 10× with the Kumar–Larson law (A = 100, α = 10; thesis eq. 5.6
    and fig. 5-5, where the exponential law leaves a "miniscule" population of
    crossing pairs) against no repulsion, in a 20-bead chain solution at c/c* ≈ 2
    (thesis §5.3.1), both runs from the same spring-avoiding start.

    Statistics: crossings are rare independent events, so the count without
    repulsion is Poisson; the test first requires at least 50 of them (relative error
    ≤ 14 %), so a ratio of 10 is resolved (the thesis's suppression is far larger)."""
    scene_free = crossing_scene(None)
    assert 1.6 < overlap_ratio(scene_free) < 2.5
    steps, chunk = 800, 200
    free, free_histogram, _ = count_crossings(scene_free, steps, chunk)
    repelled, repelled_histogram, state = count_crossings(crossing_scene({}), steps, chunk)
    print(
        f"crossings: {free} without repulsion, {repelled} with; closest 5 bins: "
        f"{free_histogram[:5].sum()} vs {repelled_histogram[:5].sum()}"
    )
    assert free >= 50, f"only {free} crossings without repulsion: too few to compare"
    assert 10 * repelled <= free, (free, repelled)
    # The repulsion's stress is recorded as its own part.
    assert "spring_repulsion" in state.virial
    # Fig. 5-5: the repulsion empties the closest bins of the spring pair histogram.
    assert repelled_histogram[:5].sum() * 10 <= free_histogram[:5].sum()


def sheared_chains(**sections):
    """The 10 × 20-bead chains of CHAINS with the default exponential repulsion, in
    Lees–Edwards shear at γ̇ = 0.5."""
    return make_scene(
        **CHAINS,
        flow={"kind": "shear", "shear_rate": 0.5},
        spring_repulsion={},
        neighbors={"spring_skin": 0.3},
        integrator={"dt": 0.005},
        **sections,
    )


@pytest.mark.slow
def test_sheared_run_writes_spring_series_and_resumes(tmp_path):
    """End to end in a Lees–Edwards box: the run writes the spring pair histogram,
    the crossing counts and the repulsion's own stress part to H5MD, and resumes from
    its checkpoint (the spring-pair list restored and reallocated)."""
    scene = sheared_chains(
        output={
            "observables": ["temperature", "pressure", "spring_pairs"],
            "checkpoint_every": 100,
        },
        run={"steps": 200, "chunk": 100},
    )
    path = tmp_path / "run.h5"
    simulate(scene, output_path=path, progress=False)
    with h5py.File(path, "r") as handle:
        observables = handle["observables"]
        assert observables["spring_pairs/histogram/value"].shape == (200, 50)
        assert observables["spring_pairs/crossings/value"].shape == (200,)
        stress = np.asarray(observables["pressure_tensor_part/spring_repulsion/value"])
    assert stress.shape == (200, 3, 3) and np.all(np.isfinite(stress))
    resumed = resume(path, steps=300, progress=False)
    assert int(resumed.state.step) == 300


@pytest.mark.slow
def test_replicas_at_two_shear_rates_share_spring_buffers():
    """The ensemble path (jaxdpd.run.ensemble): replicas at two shear rates stack with one
    spring-pair buffer shape and run without error flags."""
    simulation = build(sheared_chains())
    batch = ensemble.replicate(simulation, simulation.init_fn(), shear_rates=[0.2, 0.5])
    batch, samples, _ = run_chunk(simulation, batch, 100)
    assert np.all(np.asarray(batch.flags) == 0)
    assert np.asarray(batch.virial["spring_repulsion"]).shape == (2, 3, 3)
