"""Property-based checks of scene validation (hypothesis) over scene dictionaries.

Valid scenes of every kind are mutated at a random place: a value of the wrong type,
a number out of range (negative, zero, huge, NaN, ±inf, beyond 64 bits), an
unknown key, a missing key.  Whatever comes out, `Scene.from_dict` either accepts
it, and then the scene survives the JSON round trip that output files rely on, or
raises TypeError/ValueError with a one-line message naming the field; never another
exception (KeyError, OverflowError, ... from deep inside).
"""

import copy
import json
import math
import tomllib

from conftest import scene_dict
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from io_runs import POLYMER_SCENE_TOML, SCENE_TOML

from jaxdpd.scene import Scene

VALID_SCENES = {
    "base": scene_dict(),
    "reference": tomllib.loads(SCENE_TOML),
    "polymers": tomllib.loads(POLYMER_SCENE_TOML),
    "hoogerbrugge_koelman": {
        "seed": 3,
        "particles": {"density": 3.0, "count": 300},
        "solvent": {"method": "hoogerbrugge_koelman", "pi0": 0.3, "omega": 1.2, "delta_pi": 0.3},
        "integrator": {"dt": 1.0},
        "run": {"steps": 10, "chunk": 5},
        "output": {"observables": ["temperature"], "checkpoint_every": 5},
    },
    "mixture": {
        "seed": 4,
        "cutoff": 1.0,
        "box": {"kind": "periodic", "lengths": [6.0, 5.0, 5.0]},
        "particles": {
            "density": 3.0,
            "species": [
                {"name": "A", "fraction": 0.5, "mass": 2.0},
                {"name": "B", "fraction": 0.5},
            ],
        },
        "solvent": {"method": "dpd", "kT": 1.0, "gamma": 4.5, "noise": "gaussian"},
        "pair": {"kind": "soft_repulsion", "a": {"A-A": 25.0, "B-B": 25.0, "A-B": 30.0}},
        "body_force": {"kind": "cosine", "amplitude": 0.1, "waves": 1},
        "neighbors": {"method": "jax_md", "format": "dense", "skin": 0.2},
        "run": {"steps": 200, "chunk": 50, "equilibration": 50},
        "output": {"path": "x.h5", "observables": ["rdf"], "rdf_max": 2.0, "trajectory_every": 100},
    },
}
for _name, _data in VALID_SCENES.items():
    Scene.from_dict(_data)  # the starting points are valid

WRONG_TYPES = st.one_of(
    st.text(max_size=4),
    st.booleans(),
    st.none(),
    st.lists(st.integers(), max_size=2),
    st.dictionaries(st.text(max_size=3), st.integers(), max_size=2),
    st.floats(allow_nan=False).filter(lambda x: x != int(x) if math.isfinite(x) else True),
)
OUT_OF_RANGE = st.one_of(
    st.sampled_from([0, -1, 0.0, -0.0, -1e-300, 1e-300, 1e308, -1e308]),
    st.sampled_from([math.nan, math.inf, -math.inf, 2**63, 2**70, -(2**70), 10**400]),
    st.integers(min_value=-(2**40), max_value=2**40),
    st.floats(),
)


def _places(data, path=()):
    """Every (path, value) below `data`, tables and lists included."""
    items = data.items() if isinstance(data, dict) else enumerate(data)
    for key, value in items:
        yield path + (key,), value
        if isinstance(value, (dict, list)):
            yield from _places(value, path + (key,))


def _parent(data, path):
    for key in path[:-1]:
        data = data[key]
    return data


def _named_key(path) -> str:
    """The innermost dictionary key of a path (list indices belong to their list)."""
    return next(str(key) for key in reversed(path) if isinstance(key, str))


def _check(data, named: str | None):
    """from_dict accepts (and the JSON round trip holds) or refuses naming `named`."""
    try:
        scene = Scene.from_dict(data)
    except (TypeError, ValueError) as error:
        message = str(error)
        assert "\n" not in message, message
        if named is not None:
            assert named in message, (named, message)
        return
    assert Scene.from_dict(json.loads(scene.to_json())) == scene


SETTINGS = settings(max_examples=150, deadline=None, suppress_health_check=[HealthCheck.too_slow])


@SETTINGS
@given(st.sampled_from(sorted(VALID_SCENES)), st.data())
def test_a_value_of_the_wrong_type_is_refused_naming_its_field(kind, data):
    scene = copy.deepcopy(VALID_SCENES[kind])
    path, old = data.draw(st.sampled_from(list(_places(scene))))
    value = data.draw(WRONG_TYPES.filter(lambda v: type(v) is not type(old)))
    if isinstance(old, float) and type(value) is int:
        return  # an integer is a valid real
    _parent(scene, path)[path[-1]] = value
    _check(scene, None if path[-1] == "a" else _named_key(path))


@SETTINGS
@given(st.sampled_from(sorted(VALID_SCENES)), st.data())
def test_a_number_out_of_range_is_refused_with_a_one_line_message(kind, data):
    scene = copy.deepcopy(VALID_SCENES[kind])
    numbers = [
        (path, value)
        for path, value in _places(scene)
        if isinstance(value, (int, float)) and not isinstance(value, bool)
    ]
    path, _ = data.draw(st.sampled_from(numbers))
    _parent(scene, path)[path[-1]] = data.draw(OUT_OF_RANGE)
    _check(scene, None)


@SETTINGS
@given(st.sampled_from(sorted(VALID_SCENES)), st.data(), st.text("abcxyz_", min_size=1))
def test_an_unknown_key_is_refused_by_name(kind, data, suffix):
    scene = copy.deepcopy(VALID_SCENES[kind])
    tables = [value for _, value in _places(scene) if isinstance(value, dict)] + [scene]
    table = data.draw(st.sampled_from(tables))
    key = f"zz_{suffix}"
    table[key] = 1.0
    try:
        Scene.from_dict(scene)
    except ValueError as error:
        assert key in str(error) and "\n" not in str(error)
    else:
        raise AssertionError(f"unknown key {key!r} accepted")


@SETTINGS
@given(st.sampled_from(sorted(VALID_SCENES)), st.data())
def test_a_missing_key_takes_its_default_or_is_named(kind, data):
    scene = copy.deepcopy(VALID_SCENES[kind])
    keyed = [path for path, _ in _places(scene) if isinstance(path[-1], str)]
    path = data.draw(st.sampled_from(keyed))
    del _parent(scene, path)[path[-1]]
    _check(scene, path[-1])
