"""Polymer scenes: validation, placement, and a FENE spring that fails loudly."""

import numpy as np
import pytest
from conftest import make_scene, scene_dict

from jaxdpd.engine import errors
from jaxdpd.engine.build import build
from jaxdpd.engine.errors import SimulationError
from jaxdpd.geometry.chain_topology import chain_coordinates
from jaxdpd.io.h5md import read_checkpoint
from jaxdpd.run.runner import simulate
from jaxdpd.scene import Scene

TWO_SPECIES = {
    "density": 3.0,
    "count": 600,
    "species": [{"name": "P", "fraction": 0.25}, {"name": "S", "fraction": 0.75}],
}
FENE = {"law": "fene", "spring_constant": 8.0, "max_extension": 2.5}  # b = 50


def polymer_scene_dict(beads=2, bond=FENE, **sections):
    return scene_dict(
        particles=TWO_SPECIES,
        polymers=[{"species": "P", "beads": beads, "bond": bond}],
        **sections,
    )


INVALID = [
    ({"polymers": {"species": "P"}}, TypeError, ["polymers", "list"]),
    ({"polymers": [{"species": "X", "beads": 2, "bond": FENE}]}, ValueError, ["X", "species"]),
    ({"polymers": [{"species": "P", "beads": 1, "bond": FENE}]}, ValueError, ["beads", "≥ 2"]),
    ({"polymers": [{"species": "P", "beads": 2}]}, ValueError, ["polymers[0].bond", "law"]),
    (
        {"polymers": [{"species": "P", "beads": 2, "bond": {**FENE, "law": "rubber"}}]},
        ValueError,
        ["bond.law", "fene"],
    ),
    (
        {"polymers": [{"species": "P", "beads": 2, "bond": {**FENE, "rest_length": 1.0}}]},
        ValueError,
        ["rest_length", "not parameters"],
    ),
    (
        {
            "polymers": [{"species": "P", "beads": 2, "bond": {**FENE, "max_extension": 5.0}}],
            "spring_repulsion": {"law": "exponential"},
        },
        ValueError,
        ["max_extension", "half the shortest box edge", "spring_repulsion"],
    ),
    (
        {"polymers": [{"species": "P", "beads": 2, "bond": {**FENE, "spring_constant": 0}}]},
        ValueError,
        ["spring_constant", "> 0"],
    ),
    (
        {
            "particles": {**TWO_SPECIES, "species": [{"name": "P", "count": 151}, {"name": "S"}]},
        },
        ValueError,
        ["151", "multiple of 2"],
    ),
    (
        {"solvent": {"method": "hoogerbrugge_koelman", "weight_density": 0.0}, "pair": None},
        ValueError,
        ["solvent.weight_density", "> 0"],
    ),
    (
        {"solvent": {"method": "hoogerbrugge_koelman", "initial_kT": -1e-3}, "pair": None},
        ValueError,
        ["solvent.initial_kT", "> 0"],
    ),
    (
        {"solvent": {"method": "hoogerbrugge_koelman", "kT": 1.0}, "pair": None},
        ValueError,
        ["kT", "initial_kT"],
    ),
]


@pytest.mark.parametrize(("changes", "error", "words"), INVALID)
def test_invalid_polymer_fields_are_named(changes, error, words):
    data = polymer_scene_dict()
    for key, value in changes.items():
        if value is None:
            data.pop(key)
        else:
            data[key] = value
    if "particles" in changes and "count" not in changes["particles"]["species"][1]:
        data["particles"]["species"][1]["count"] = 449
    with pytest.raises(error) as raised:
        Scene.from_dict(data)
    for word in words:
        assert word in str(raised.value), (word, str(raised.value))


def test_conformation_needs_polymers():
    with pytest.raises(ValueError, match="conformation.*polymers"):
        make_scene(output={"observables": ["conformation"]})


def test_fractions_round_to_whole_chains_and_the_scene_round_trips():
    data = polymer_scene_dict(beads=7)
    scene = Scene.from_dict(data)
    counts = {s.name: s.count for s in scene.particles.species}
    assert counts["P"] % 7 == 0 and abs(counts["P"] - 150) <= 3
    assert sum(counts.values()) == 600
    assert Scene.from_dict(scene.to_dict()) == scene


def test_chains_start_in_one_piece_at_the_placement_length():
    """Springs start at the FENE equilibrium length Q0 √(3/(b+5)) (thesis eq. 4.8),
    and image counters agree with the chain coordinates rebuilt by minimum image
    (thesis eq. 3.6)."""
    scene = Scene.from_dict(polymer_scene_dict(beads=5, pair=None, solvent={"gamma": 0.0}))
    simulation = build(scene)
    state = simulation.init_fn()
    (block,) = simulation.blocks
    chains = chain_coordinates(simulation.box, state.positions, block)
    springs = np.linalg.norm(np.diff(chains, axis=1), axis=-1)
    np.testing.assert_allclose(springs, 2.5 * np.sqrt(3 / 55), rtol=1e-12)
    unwrapped = block.take(simulation.box.unwrap(state.positions, state.image))
    shift = unwrapped - chains  # a whole number of box lengths, the same for each bead
    np.testing.assert_allclose(shift, shift[:, :1].repeat(5, axis=1), atol=1e-9)
    assert int(state.flags) == 0


def test_overstretched_fene_spring_stops_the_run_with_a_message(tmp_path):
    """Stiff FENE springs (ω Δt ≈ 3, far past velocity Verlet's stability limit 2)
    alone, without pair forces: the run stops at the end of the chunk, names the
    spring, and leaves a finite checkpoint; never NaN output."""
    bond = {"law": "fene", "spring_constant": 60.0, "max_extension": 1.2}
    scene = Scene.from_dict(
        polymer_scene_dict(
            bond=bond,
            pair=None,
            solvent={"gamma": 0.0},
            integrator={"dt": 0.3},
            run={"steps": 200, "chunk": 20},
        )
    )
    path = tmp_path / "stretched.h5"
    with pytest.raises(SimulationError, match="FENE spring") as raised:
        simulate(scene, output_path=path, progress=False)
    assert "integrator.dt" in str(raised.value)
    checkpoint = read_checkpoint(path)
    assert np.all(np.isfinite(checkpoint["positions"]))
    assert checkpoint["flags"] == 0  # the last good state


def test_error_messages_name_every_flag():
    for bit in errors.StepError:
        assert errors.describe(bit) == bit.message != ""
    assert errors.describe(0) == "no error"


def test_error_flags_are_described_cause_first():
    """An int32 read from the state names each set bit, the spring failure before
    the non-finite values it led to; bits no member names are ignored."""
    flags = np.int32(errors.StepError.NON_FINITE | errors.StepError.SPRING_OVERSTRETCHED | 1 << 20)
    assert errors.describe(flags) == "; ".join(
        (errors.StepError.SPRING_OVERSTRETCHED.message, errors.StepError.NON_FINITE.message)
    )
