"""The MPCD scene fields: validation names the field, the value and what is valid; the
resolved scene round-trips."""

import copy

import pytest
from mpcd_scenes import polymer_solution

from jaxdpd.scene import Scene

BASE = polymer_solution()


def _scene(**changes):
    data = copy.deepcopy(BASE)
    for path, value in changes.items():
        section, _, key = path.partition("__")
        if key:
            data[section][key] = value
        elif value is None:
            del data[section]
        else:
            data[section] = value
    return data


INVALID = [
    (_scene(solvent__cell_size=0.7), ValueError, ["solvent.cell_size", "L_x", "whole multiple"]),
    (_scene(solvent__cell_size=6.0), ValueError, ["solvent.cell_size", "≥ 2"]),
    (_scene(integrator={"dt": 0.03}), ValueError, ["integrator.dt", "collision_time", "whole"]),
    (_scene(integrator={"dt": 0.01, "lambda": 0.65}), ValueError, ["integrator.lambda", "0.5"]),
    (_scene(solvent__rotation_angle=0.0), ValueError, ["solvent.rotation_angle", "> 0"]),
    (_scene(solvent__rotation_angle=200.0), ValueError, ["solvent.rotation_angle", "≤ 180"]),
    (_scene(solvent__collision_time=-0.1), ValueError, ["solvent.collision_time", "> 0"]),
    (
        _scene(solvent__thermostat="berendsen"),
        ValueError,
        ["solvent.thermostat", "maxwell_boltzmann_scaling"],
    ),
    (_scene(solvent__collision="pairs"), ValueError, ["solvent.collision", "particle"]),
    (_scene(solvent__gamma=4.5), ValueError, ["gamma", "method 'dpd'", "not 'mpcd'"]),
    (
        _scene(solvent={"method": "dpd", "cell_size": 1.0}),
        ValueError,
        ["cell_size", "method 'mpcd'", "not 'dpd'"],
    ),
    (
        _scene(solvent__collision="particle"),
        ValueError,
        ["solvent.collision = 'particle'", "Rouse", "solvent"],
    ),
    (
        _scene(
            particles={
                "density": 5.0,
                "species": [
                    {"name": "a", "count": 40},
                    {"name": "solvent", "count": 1000},
                    {"name": "b", "count": 40},
                ],
            },
            polymers=[
                {"species": "a", "beads": 10, "bond": {"law": "hookean", "spring_constant": 3.0}},
                {"species": "b", "beads": 10, "bond": {"law": "hookean", "spring_constant": 3.0}},
            ],
        ),
        ValueError,
        ["particles.species", "adjacent"],
    ),
    (
        _scene(polymers=None, pair={"kind": "soft_repulsion", "a": 25.0}),
        ValueError,
        ["pair", "[[polymers]]", "feel no forces"],
    ),
    (
        _scene(
            box={"lengths": [6, 6, 8]},
            particles={"density": 5.0},
            polymers=None,
            output={"observables": ["transverse_current"]},
        ),
        ValueError,
        ["transverse_current", "cubic"],
    ),
]


@pytest.mark.parametrize(("data", "error", "words"), INVALID)
def test_invalid_mpcd_field_is_named(data, error, words):
    with pytest.raises(error) as raised:
        Scene.from_dict(data)
    for word in words:
        assert word in str(raised.value), str(raised.value)


def test_mpcd_scene_resolves_and_round_trips():
    scene = Scene.from_dict(_scene())
    assert scene.solvent.cell_size == 1.0 and scene.solvent.thermostat == "none"
    assert scene.solvent.collision == "cell"
    assert scene.step_time == 0.1 and scene.integrator.dt == 0.01
    assert Scene.from_dict(scene.to_dict()) == scene
    assert scene.to_dict()["solvent"] == {
        "method": "mpcd",
        "kT": 1.0,
        "cell_size": 1.0,
        "rotation_angle": 130.0,
        "collision_time": 0.1,
        "thermostat": "none",
        "collision": "cell",
    }
    # Without [integrator], monomers take one velocity-Verlet step per collision.
    data = _scene(integrator=None)
    assert Scene.from_dict(data).integrator.dt == 0.1
