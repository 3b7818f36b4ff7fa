"""`jaxdpd.simulate`: a scene in, its state and per-step observables out, in one call.

The familiar entry point of jax-md or HOOMD-blue users: build the scene, draw its
initial state (or continue a given one), and run the chunked driver
(jaxdpd.run.driver: neighbour buffers grown on overflow, a clear error on anything
else) for a number of steps, keeping every per-step series in memory.  It writes no
file, runs no separate equilibration and prints nothing: `jaxdpd run` and
jaxdpd.run.runner do those (H5MD output, checkpoints, block averages, summary).
"""

from pathlib import Path
from typing import NamedTuple

import numpy as np

from jaxdpd.engine.build import build
from jaxdpd.run import driver
from jaxdpd.scene import Scene


class Trajectory(NamedTuple):
    """What `simulate` returns.

    Attributes:
        state: the SimState after the last step (continue with `simulate(scene,
            steps, state=state)`, which reuses the compiled step).
        observables: name -> NumPy array (steps, ...) of each series the scene's
            output.observables sample, one row per step ("temperature",
            "pressure_tensor", "<species>/bond_length_sq", ...).
    """

    state: object
    observables: dict


def as_scene(scene) -> Scene:
    """A Scene from a Scene, a dict of scene sections, or the path of a TOML file."""
    if isinstance(scene, Scene):
        return scene
    if isinstance(scene, dict):
        return Scene.from_dict(scene)
    if isinstance(scene, str | Path):
        return Scene.from_toml(scene)
    raise TypeError(
        f"scene: expected a Scene, a dict or the path of a TOML file, got {type(scene).__name__}"
    )


def simulate(scene, steps: int | None = None, state=None) -> Trajectory:
    """Run `steps` steps of `scene` from its initial state or from `state`.

    Args:
        scene: a Scene, a dict of its sections, or a TOML file's path.
        steps: number of steps (default: the scene's run.steps); run in chunks of
            run.chunk steps.
        state: a SimState of this scene to continue from (default: `init_fn()`, the
            scene's seeded initial state).
    Returns:
        Trajectory(state, observables).
    Raises:
        SimulationError: a chunk set an error flag (non-finite values, ...).
    """
    scene = as_scene(scene)
    steps = scene.run.steps if steps is None else steps
    simulation = build(scene)
    state = simulation.init_fn() if state is None else state
    chunks = []
    final = driver.run(
        simulation, state, steps, scene.run.chunk, lambda result: chunks.append(result.series)
    )
    names = chunks[0] if chunks else {}
    return Trajectory(final, {name: np.concatenate([c[name] for c in chunks]) for name in names})
