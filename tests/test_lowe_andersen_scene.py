"""Scene fields of the Lowe–Andersen solvent: validation, resolution, round trip."""

import pytest
from conftest import scene_dict

from jaxdpd.scene import Scene

LOWE_ANDERSEN = {"method": "lowe_andersen", "kT": 1.0, "collision_frequency": 50.0}


def lowe_andersen_dict(solvent=None, **sections):
    """The small test scene with a Lowe–Andersen solvent at Δt = 0.01."""
    data = scene_dict(integrator={"dt": 0.01}, **sections)
    data["integrator"].pop("lambda")
    data["solvent"] = {**LOWE_ANDERSEN, **(solvent or {})}
    return data


INVALID = [
    # (solvent fields, other sections, exception, words the message must contain)
    (
        {"collision_frequency": 150.0},
        {},
        ValueError,
        [
            "collision_frequency × integrator.dt",
            "150 × 0.01 = 1.5 > 1",
            "collision_frequency ≤ 1/dt = 100",
            "integrator.dt ≤ 1/collision_frequency = 0.00666",
        ],
    ),
    ({"collision_frequency": -1.0}, {}, ValueError, ["solvent.collision_frequency", "≥ 0"]),
    ({"collision_frequency": "fast"}, {}, TypeError, ["solvent.collision_frequency", "number"]),
    ({"kT": 0.0}, {}, ValueError, ["solvent.kT", "> 0"]),
    ({"thermalization_cutoff": 0.0}, {}, ValueError, ["solvent.thermalization_cutoff", "> 0"]),
    (
        {"thermalization_cutoff": 3.0},
        {},
        ValueError,
        ["box.lengths", "2 (solvent.thermalization_cutoff + neighbors.skin)"],
    ),
    ({"gamma": 4.5}, {}, ValueError, ["['gamma']", "not parameters of method 'lowe_andersen'"]),
    ({"noise": "gaussian"}, {}, ValueError, ["['noise']", "not parameters"]),
    ({"pi0": 0.3}, {}, ValueError, ["['pi0']", "not parameters"]),
    ({}, {"integrator": {"dt": 0.01, "lambda": 0.65}}, ValueError, ["integrator.lambda", "λ"]),
]


@pytest.mark.parametrize(("solvent", "sections", "error", "words"), INVALID)
def test_invalid_lowe_andersen_field_is_named(solvent, sections, error, words):
    data = lowe_andersen_dict(solvent)
    data.update(sections)
    with pytest.raises(error) as raised:
        Scene.from_dict(data)
    for word in words:
        assert word in str(raised.value), str(raised.value)


def test_collision_frequency_is_required():
    data = lowe_andersen_dict()
    del data["solvent"]["collision_frequency"]
    with pytest.raises(ValueError, match=r"solvent.collision_frequency: required"):
        Scene.from_dict(data)


def test_other_methods_refuse_lowe_andersen_fields():
    data = scene_dict()
    data["solvent"] = {"method": "dpd", "gamma": 4.5, "collision_frequency": 10.0}
    with pytest.raises(ValueError, match=r"\['collision_frequency'\] belong to method 'lowe"):
        Scene.from_dict(data)


def test_unit_collision_probability_is_allowed_and_round_trips():
    """ΓΔt = 1 exactly (every pair within r_T, every step) is the largest allowed."""
    scene = Scene.from_dict(lowe_andersen_dict({"collision_frequency": 100.0}))
    assert scene.solvent.collision_frequency * scene.integrator.dt == pytest.approx(1.0)
    assert "lambda" not in scene.to_dict()["integrator"]
    assert Scene.from_dict(scene.to_dict()) == scene
    assert scene.solvent_component.bath_cutoff(scene) == scene.cutoff  # r_T defaults to r_c


def test_thermalization_cutoff_resolution():
    scene = Scene.from_dict(lowe_andersen_dict({"thermalization_cutoff": 1.2}))
    assert scene.solvent_component.bath_cutoff(scene) == 1.2
    assert Scene.from_dict(scene.to_dict()) == scene
    off = Scene.from_dict(lowe_andersen_dict({"collision_frequency": 0.0}))
    assert off.solvent_component.bath_cutoff(off) is None  # Γ = 0: no thermostat is composed


def test_polymers_may_use_a_lowe_andersen_solvent():
    species = [{"name": "P", "fraction": 0.25}, {"name": "S", "fraction": 0.75}]
    bond = {"law": "fene", "spring_constant": 8.0, "max_extension": 2.5}
    data = lowe_andersen_dict(
        particles={"density": 3.0, "count": 600, "species": species},
        polymers=[{"species": "P", "beads": 2, "bond": bond}],
    )
    assert Scene.from_dict(data).polymers[0].beads == 2
