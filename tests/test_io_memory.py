"""A run of many chunks streams its output: memory does not grow with its length.

Measured on the shared reference run (io_runs: 120 chunks of 20 steps, 375
particles, per-step temperature, pressure and pressure tensors, a frame at every
chunk, a checkpoint every 5), between chunk 40 and chunk 120 (80 chunks):

- traced Python/NumPy allocations (tracemalloc, started at chunk 20 so that both
  ends hold the objects of a current chunk, frame and checkpoint).  A runner keeping
  its output would grow by at least the bytes of the series produced in the window
  (80 × 20 steps × 376 B = 601 600 B) or of the frames (80 × 375 × 3 × 20 B =
  1 800 000 B).  What remains in a streaming run is the slow filling of bounded
  caches in NumPy, JAX and h5py: 10–16 kB measured.  Bound: a quarter of the smaller
  of the two, 150 kB: 10× above what was measured, 4× below what keeping either
  would cost.  The control run with keep_series=True shows the measurement sees it.
- live JAX arrays: a retained device array per chunk would add 80; the bound is 10.
"""

import numpy as np
import pytest
from io_runs import MEMORY_WINDOW, MemoryProbe, reference_run

from jaxdpd.run.runner import simulate


def _window_bounds(scene, probe) -> float:
    chunks = MEMORY_WINDOW[1] - MEMORY_WINDOW[0]
    frames = chunks * scene.run.chunk // scene.output.trajectory_every
    frame_bytes = frames * scene.n_particles * 3 * (8 + 8 + 4)  # positions, velocities, images
    return min(probe.series_bytes, frame_bytes) / 4


def test_memory_stays_flat_over_80_chunks_of_a_streamed_run():
    reference = reference_run()
    memory = reference.memory
    growth = memory.traced[1] - memory.traced[0]
    assert memory.series_bytes == 80 * 20 * (8 + 8 + 5 * 72)  # T, p, 5 tensors per step
    assert growth < _window_bounds(reference.scene, memory), (growth, memory.series_bytes)
    assert memory.live_arrays[1] - memory.live_arrays[0] < 10


# The control reruns the whole reference run (≈ 45 s) to show the probe can fail;
# needed when the probe or the bounds change: -m slow.  The streaming test above stays
# in the default run.
@pytest.mark.slow
def test_the_memory_probe_sees_series_kept_in_memory(tmp_path):
    """Control: the same run keeping its series (keep_series=True) grows past the
    bound, so the streaming test above can fail."""
    probe, scene = MemoryProbe(), reference_run().scene
    path = tmp_path / "kept.h5"
    summary = simulate(scene, path, progress=False, on_chunk=probe, keep_series=True)
    assert len(summary.series["temperature"]) == scene.run.steps
    assert np.all(np.isfinite(summary.series["pressure"]))
    assert probe.traced[1] - probe.traced[0] > _window_bounds(scene, probe)
