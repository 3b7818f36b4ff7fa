"""jaxdpd: differentiable, vectorised mesoscale simulation of polymer solutions.

Units are reduced DPD units (r_c = m = k_BT = 1) unless a scene says otherwise.

    scene = jaxdpd.Scene.from_toml("scene.toml")      # declarative, validated
    simulation = jaxdpd.build(scene)                  # init_fn, step_fn (pure, jittable)
    state, observables = jaxdpd.simulate(scene, 1000) # build, init, run in chunks
    record = jaxdpd.load("run.h5md")                  # a run file, nothing compiled

Importing jaxdpd is cheap and leaves JAX alone: these names are imported on first
use (PEP 562), and JAX with them.  Building a scene switches on JAX's 64-bit types,
which the engine needs (see jaxdpd.precision); call `enable_float64()` first to
make float64 JAX arrays of your own.
"""

import importlib

__version__ = "0.1.0"

# name -> module defining it, imported when the name is first used.
_LAZY = {
    "Scene": "jaxdpd.scene",
    "build": "jaxdpd.engine.build",
    "simulate": "jaxdpd.run.api",
    "load": "jaxdpd.io.reader",
    "enable_float64": "jaxdpd.precision",
}

__all__ = sorted(_LAZY)


def __getattr__(name: str):
    if name not in _LAZY:
        raise AttributeError(f"module 'jaxdpd' has no attribute {name!r}")
    value = getattr(importlib.import_module(_LAZY[name]), name)
    globals()[name] = value
    return value


def __dir__():
    return sorted(set(globals()) | set(_LAZY))
