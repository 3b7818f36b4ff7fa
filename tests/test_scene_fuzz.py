"""Fuzzing every scene field (issue 28, items 8–9): huge, extreme, negative, NaN and
wrong-type values, alone or several at once, must either build or be refused with a
ValueError/TypeError naming a scene field, before anything is allocated; never
another exception, never a hang (a per-example time limit).

The fields are those of the scenes' own `to_dict()` (every field a scene resolves,
defaults included) of a few base scenes covering the solvents, a sheared polymer
solution with its observables, plus the optional fields they leave out.  The default
run tries a few examples (seconds); the slow tests many, and draw each accepted
scene's initial state (placement and the first neighbour-list build, where scenes
used to hang).
"""

import copy
import math
import re
import threading

import pytest
from conftest import scene_dict
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from mpcd_scenes import pure_solvent

from jaxdpd.engine.build import build
from jaxdpd.scene import Scene

SECTIONS = (
    "seed|precision|cutoff|box|particles|solvent|pair|integrator|polymers|flow|neighbors|"
    "run|output|body_force|spring_repulsion"
)
NAMES_A_FIELD = re.compile(rf"\b({SECTIONS})\b")


def _base_scenes() -> list[dict]:
    sheared_chains = scene_dict(
        flow={"kind": "shear", "shear_rate": 0.5},
        particles={
            "density": 3.0,
            "count": 375,
            "species": [{"name": "chain", "count": 75}, {"name": "solvent", "count": 300}],
        },
        polymers=[
            {
                "species": "chain",
                "beads": 5,
                "bond": {"law": "fene", "spring_constant": 4.0, "max_extension": 2.0},
            }
        ],
        output={
            "observables": ["temperature", "pressure", "conformation", "dynamics", "profile"],
            "trajectory_every": 50,
        },
    )
    lowe_andersen = scene_dict(
        solvent={"method": "lowe_andersen", "kT": 1.0, "collision_frequency": 4.5},
        output={"observables": ["temperature", "rdf"], "rdf_max": 2.5},
    )
    del lowe_andersen["solvent"]["gamma"], lowe_andersen["integrator"]["lambda"]
    scenes = [scene_dict(), sheared_chains, lowe_andersen, pure_solvent(5.0, 130.0, 0.1, 4.0)]
    return [Scene.from_dict(data).to_dict() for data in scenes]


BASES = _base_scenes()
# Optional fields the resolved scenes leave out.
EXTRA_FIELDS = (("particles", "density"), ("solvent", "sigma"), ("box", "lengths", 1))


def _fields(node, path=()):
    """Every path to a leaf (and to each section and list) of a scene dictionary."""
    if path:
        yield path
    if isinstance(node, dict):
        for key, value in node.items():
            yield from _fields(value, (*path, key))
    elif isinstance(node, list):
        for index, value in enumerate(node):
            yield from _fields(value, (*path, index))


FIELDS = sorted({path for base in BASES for path in _fields(base)} | set(EXTRA_FIELDS), key=str)

EXTREME_VALUES = st.one_of(
    st.sampled_from(
        [0, -1, 1, 2**31 - 1, 2**31, 2**62, 10**12, 10**30, -(2**63), 2**64, 0.0, -0.0, 1e-300]
    ),
    st.sampled_from([1e7, 1e12, 1e300, -1e300, math.nan, math.inf, -math.inf, 0.5, 3.0]),
    st.sampled_from([True, None, "", "x", "dpd", "lees_edwards", "float16"]),
    st.sampled_from([[], [1], [1e12, 1e12, 1e12], [0.1, 0.1, 0.1], {}, {"kind": "x"}]),
    st.integers(min_value=-(2**70), max_value=2**70),
    st.floats(allow_nan=True, allow_infinity=True),
)


def _set(data: dict, path: tuple, value) -> None:
    """Put `value` at `path` (creating missing sections; a missing list slot
    replaces the whole list)."""
    node = data
    for key in path[:-1]:
        if isinstance(node, dict):
            node = node.setdefault(key, {})
        elif isinstance(node, list) and isinstance(key, int) and key < len(node):
            node = node[key]
        else:
            return
        if not isinstance(node, (dict, list)):
            return
    last = path[-1]
    if isinstance(node, dict):
        node[last] = value
    elif isinstance(node, list) and isinstance(last, int) and last < len(node):
        node[last] = value


class Hang(Exception):
    pass


def check_scene(data: dict, seconds: int, initial_state: bool) -> None:
    """Build the scene (and draw its initial state) in a worker thread, waiting at
    most `seconds`.  A thread rather than a SIGALRM handler, whose exception lands
    wherever the main thread is, possibly inside JAX's compiler or its cache write,
    and may leave them in a state that a later test trips over.  A build that does
    not finish keeps its (daemon) thread after the test has failed."""
    outcome = {}

    def attempt():
        try:
            simulation = build(Scene.from_dict(data))
            if initial_state:
                simulation.init_fn()
        except BaseException as error:  # handed to the test's thread below
            outcome["error"] = error

    worker = threading.Thread(target=attempt, daemon=True)
    worker.start()
    worker.join(seconds)
    if worker.is_alive():
        raise Hang(f"no answer within {seconds} s")
    error = outcome.get("error")
    if isinstance(error, (ValueError, TypeError)):
        assert NAMES_A_FIELD.search(str(error)), f"names no field: {error!r}"
    elif error is not None:
        raise error


def mutated_scenes(max_mutations: int):
    mutation = st.tuples(st.sampled_from(FIELDS), EXTREME_VALUES)
    return st.tuples(st.sampled_from(BASES), st.lists(mutation, min_size=1, max_size=max_mutations))


def _apply(base, mutations) -> dict:
    data = copy.deepcopy(base)
    for path, value in mutations:
        _set(data, path, copy.deepcopy(value))
    return data


@settings(max_examples=25, deadline=None, suppress_health_check=list(HealthCheck))
@given(mutated_scenes(max_mutations=2))
def test_extreme_scene_fields_are_refused_by_name_or_build(example):
    base, mutations = example
    check_scene(_apply(base, mutations), seconds=20, initial_state=False)


@pytest.mark.slow  # 400 scenes built, 100 initial states drawn: a few minutes
@settings(max_examples=400, deadline=None, suppress_health_check=list(HealthCheck))
@given(mutated_scenes(max_mutations=3))
def test_extreme_scene_fields_many(example):
    base, mutations = example
    check_scene(_apply(base, mutations), seconds=60, initial_state=False)


@pytest.mark.slow
@settings(max_examples=100, deadline=None, suppress_health_check=list(HealthCheck))
@given(mutated_scenes(max_mutations=1))
def test_extreme_scene_fields_draw_their_initial_state(example):
    base, mutations = example
    check_scene(_apply(base, mutations), seconds=300, initial_state=True)
