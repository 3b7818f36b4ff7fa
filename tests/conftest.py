"""Shared helpers: small scenes for fast tests."""

import copy
import os
import tempfile

# XLA compilation is most of the test time; tests (and the command-line runs they
# start, which inherit the environment) build the same small scenes again and again, so
# compiled programs are shared through JAX's persistent cache (keyed by the program, the
# JAX version and the flags: a changed program never hits a stale entry).
os.environ.setdefault(
    "JAX_COMPILATION_CACHE_DIR",
    os.path.join(tempfile.gettempdir(), f"jaxdpd-tests-xla-cache-{os.getuid()}"),
)
os.environ.setdefault("JAX_PERSISTENT_CACHE_MIN_COMPILE_TIME_SECS", "0.05")

import jax  # noqa: E402  (after the cache settings it reads)
import pytest  # noqa: E402

import jaxdpd  # noqa: E402
from jaxdpd.scene import Scene  # noqa: E402

jax.config.update("jax_compilation_cache_dir", os.environ["JAX_COMPILATION_CACHE_DIR"])
jax.config.update(
    "jax_persistent_cache_min_compile_time_secs",
    float(os.environ["JAX_PERSISTENT_CACHE_MIN_COMPILE_TIME_SECS"]),
)

# The tests call engine internals (boxes, neighbour lists, forces) on float64 arrays
# of their own, before or without a build: switch 64-bit types on for the session.
jaxdpd.enable_float64()

BASE_SCENE = {
    "seed": 7,
    "precision": "float64",
    "particles": {"density": 3.0, "count": 600},
    "solvent": {"method": "dpd", "kT": 1.0, "gamma": 4.5},
    "pair": {"a": 25.0},
    "integrator": {"dt": 0.04, "lambda": 0.5},
    "run": {"steps": 100, "chunk": 50},
    "output": {"observables": ["temperature", "pressure"]},
}


def scene_dict(**sections) -> dict:
    """BASE_SCENE with sections merged (a value of None removes the section)."""
    data = copy.deepcopy(BASE_SCENE)
    for name, value in sections.items():
        if value is None:
            data.pop(name, None)
        elif isinstance(value, dict) and isinstance(data.get(name), dict):
            data[name] = {**data[name], **value}
        else:
            data[name] = value
    return data


def make_scene(**sections) -> Scene:
    """A validated small scene (600 particles, ρ = 3, float64 unless overridden)."""
    return Scene.from_dict(scene_dict(**sections))


@pytest.fixture
def small_scene():
    return make_scene()
