"""A run of many chunks streams its output: memory does not grow with its length.

Measured on the shared reference run (io_runs: 120 chunks of 20 steps, 375
particles, per-step temperature, pressure and pressure tensor, a frame every 10
chunks, a checkpoint every 5), between chunk 40 and chunk 120 (80 chunks):

- traced Python/NumPy allocations (tracemalloc, started at chunk 20 so that both
  ends hold the objects of a current chunk, frame and checkpoint).  Keeping the
  series in memory, as the runner once did, would grow by at least the bytes of the
  series produced in the window (140 800 B here), and keeping the frames by another
  4 × 375 × 3 × 20 B = 90 000 B.  What remains in a streaming run is the slow filling
  of bounded caches in NumPy and JAX (measured: 7–11 % of the series bytes, falling
  as the run goes on).  Bound: one third of the series bytes, 3× above what was
  measured and 3× below what keeping the series would cost; the control run with
  keep_series=True shows the measurement sees that cost.
- live JAX arrays: a retained device array per chunk would add 80; the bound is 10.
"""

from io_runs import MemoryProbe, reference_run

from jaxdpd.runner import simulate


def test_memory_stays_flat_over_80_chunks_of_a_streamed_run():
    memory = reference_run().memory
    growth = memory.traced[1] - memory.traced[0]
    assert memory.series_bytes == 80 * 20 * (8 + 8 + 72)  # temperature, pressure, tensor
    assert growth < memory.series_bytes / 3, (growth, memory.series_bytes)
    assert memory.live_arrays[1] - memory.live_arrays[0] < 10


def test_the_memory_probe_sees_series_kept_in_memory(tmp_path):
    """Control: the same run keeping its series (keep_series=True) grows past the
    bound, so the streaming test above can fail."""
    probe, scene = MemoryProbe(), reference_run().scene
    path = tmp_path / "kept.h5"
    summary = simulate(scene, path, progress=False, on_chunk=probe, keep_series=True)
    assert len(summary.series["temperature"]) == scene.run.steps
    assert probe.traced[1] - probe.traced[0] > probe.series_bytes / 3
