"""Shared, fully written runs for the I/O tests (each built and compiled once per
test session, in a temporary directory removed at exit).

`reference_run()` runs SCENE_TOML uninterrupted, writing an H5MD file, and records on
the way the memory held between chunk 10 and chunk 100 (traced Python/NumPy
allocations, live JAX arrays) for the streaming test.  Tests that restart,
interrupt or read runs of the same scene reuse its compiled step.
"""

import atexit
import functools
import gc
import re
import shutil
import tempfile
import tracemalloc
from dataclasses import dataclass, field
from pathlib import Path

import jax
import numpy as np

from jaxdpd.io import read_checkpoint, read_observables, read_trajectory
from jaxdpd.io.checkpoint import checkpoint_path
from jaxdpd.io.reader import open_run_file
from jaxdpd.run.restore import restore
from jaxdpd.run.runner import simulate
from jaxdpd.scene import Scene

# 375 particles (a 5³ box at ρ = 3), float64, in Lees–Edwards shear (a box state in
# SimState); 120 chunks of 20 steps.  Checkpoints by step count only (no wall-clock
# ones, checkpoint_seconds = 0), so that tests know where they are.
SCENE_TOML = """
seed = 11
precision = "float64"
[particles]
density = 3.0
count = 375
[solvent]
method = "dpd"
gamma = 4.5
[pair]
a = 25.0
[flow]
kind = "shear"
shear_rate = 0.5
[integrator]
dt = 0.04
[run]
steps = 2400
chunk = 20
[output]
observables = ["temperature", "pressure"]
trajectory_every = 20
checkpoint_every = 100
checkpoint_seconds = 0
"""
# Memory growth is measured between these chunks (tracing starts at TRACE_FROM, so
# that the objects of the current chunk exist, traced, at both ends; both ends write
# a frame and a checkpoint).
TRACE_FROM, MEMORY_WINDOW = 20, (40, 120)


def reference_scene() -> Scene:
    return Scene.from_toml_string(SCENE_TOML)


def lees_edwards_edges(scene, step: int) -> np.ndarray:
    """Lattice vectors (rows) of the sheared box after `step` steps at constant rate:
    a2 = (Δ, L_y, 0) with Δ = γ̇ L_y t folded into [−L_x/2, L_x/2) (thesis §3.3)."""
    lx, ly, lz = scene.box.lengths
    offset = scene.flow.shear_rate * ly * step * scene.integrator.dt
    offset -= lx * np.floor(offset / lx + 0.5)
    return np.array([[lx, 0.0, 0.0], [offset, ly, 0.0], [0.0, 0.0, lz]])


@dataclass
class MemoryProbe:
    """Traced allocations and live JAX arrays at the two ends of MEMORY_WINDOW, and
    the bytes of series the run produced in between (what keeping them would cost)."""

    chunk: int = 0
    traced: list = field(default_factory=list)
    live_arrays: list = field(default_factory=list)
    series_bytes: int = 0

    def __call__(self, result) -> None:
        self.chunk += 1
        first, last = MEMORY_WINDOW
        if first < self.chunk <= last:
            self.series_bytes += sum(np.asarray(v).nbytes for v in result.series.values())
        if self.chunk == TRACE_FROM:
            tracemalloc.start()
        if self.chunk in (first, last):
            gc.collect()
            self.traced.append(tracemalloc.get_traced_memory()[0])
            self.live_arrays.append(len(jax.live_arrays()))
            if self.chunk == last:
                tracemalloc.stop()


@dataclass
class ReferenceRun:
    path: object
    scene: Scene
    summary: object
    memory: MemoryProbe


def _scratch(name: str) -> Path:
    folder = tempfile.mkdtemp(prefix=f"jaxdpd-{name}-")
    atexit.register(shutil.rmtree, folder, ignore_errors=True)
    return Path(folder) / f"{name}.h5md"


@functools.cache
def reference_run() -> ReferenceRun:
    """SCENE_TOML run uninterrupted (150 chunks), with its memory probe."""
    scene = reference_scene()
    path = _scratch("reference")
    probe = MemoryProbe()
    summary = simulate(scene, output_path=path, progress=False, on_chunk=probe)
    return ReferenceRun(path, scene, summary, probe)


def assert_same_run(path, reference) -> None:
    """The run in `path` ended exactly as the uninterrupted `reference` run."""
    assert_same_leaves(restore(path)[1], reference.summary.state)
    ours, theirs = read_observables(path), read_observables(reference.path)
    assert ours.keys() == theirs.keys()
    for name in theirs:
        for a, b in zip(ours[name], theirs[name], strict=True):
            np.testing.assert_array_equal(a, b, err_msg=name)
    for element in ("position", "velocity", "image"):
        for a, b in zip(
            read_trajectory(path, element), read_trajectory(reference.path, element), strict=True
        ):
            np.testing.assert_array_equal(a, b, err_msg=element)
    with open_run_file(path) as mine, open_run_file(reference.path) as other:
        for name in _datasets(other, "averages"):  # g(r), time correlations
            np.testing.assert_array_equal(mine[name][()], other[name][()], err_msg=name)
    assert read_checkpoint(path)["reason"] == "end of run"


def _datasets(handle, root: str) -> list[str]:
    names = []
    if root in handle:
        handle[root].visititems(
            lambda name, item: names.append(f"{root}/{name}") if hasattr(item, "dtype") else None
        )
    return names


def copy_run(source, target) -> None:
    """Copy a run file and its checkpoint file (jaxdpd.io.checkpoint)."""
    shutil.copyfile(source, target)
    shutil.copyfile(checkpoint_path(source), checkpoint_path(target))


def _structure(tree) -> str:
    """The tree structure as text, with object addresses removed: a jax-md neighbour
    list holds functions in its structure, equal in kind but not in identity."""
    return re.sub(r" at 0x[0-9a-f]+", "", str(jax.tree_util.tree_structure(tree)))


def assert_same_leaves(state, expected) -> None:
    """Every leaf of two pytrees equal in path, dtype, shape and bits."""
    ours = jax.tree_util.tree_flatten_with_path(state)
    theirs = jax.tree_util.tree_flatten_with_path(expected)
    assert _structure(state) == _structure(expected), "tree structures differ"
    for (path, a), (_, b) in zip(ours[0], theirs[0], strict=True):
        a, b = np.asarray(a), np.asarray(b)
        name = jax.tree_util.keystr(path)
        assert a.dtype == b.dtype and a.shape == b.shape, name
        assert a.tobytes() == b.tobytes(), f"{name} differs"


# FENE dumbbells in a DPD solvent, float32, equilibration, frames and periodic
# checkpoints in both phases, every observable for a box at rest, on-device
# correlators (SimState.observers).  Wall-clock checkpoints once an hour: never in a
# test, but for the one that fakes the clock.  (The cell list: jax-md's lists get a
# new update function, a static field, at every allocation, so each run of a jax-md
# scene compiles its chunks again; test_restart runs one as a slow test.)
POLYMER_SCENE_TOML = """
seed = 5
precision = "float32"
[particles]
density = 3.0
count = 192
species = [{ name = "dumbbell", count = 48 }, { name = "solvent", count = 144 }]
[solvent]
method = "dpd"
gamma = 4.5
[pair]
a = 25.0
[[polymers]]
species = "dumbbell"
beads = 2
bond = { law = "fene", spring_constant = 10.0, max_extension = 1.5 }
[run]
equilibration = 40
steps = 100
chunk = 10
[output]
observables = ["temperature", "pressure", "conformation", "dynamics", "rdf"]
correlator_every = 5
correlator_levels = 3
rdf_max = 1.5
rdf_bins = 30
trajectory_every = 20
checkpoint_every = 30
checkpoint_seconds = 3600
"""


def polymer_scene() -> Scene:
    return Scene.from_toml_string(POLYMER_SCENE_TOML)


@functools.cache
def polymer_reference_run() -> ReferenceRun:
    """POLYMER_SCENE_TOML run uninterrupted."""
    scene = polymer_scene()
    path = _scratch("polymer")
    summary = simulate(scene, output_path=path, progress=False)
    return ReferenceRun(path, scene, summary, None)
