"""`simulate(scene)`: build, equilibrate, run in chunks, measure, write, summarise.

This is what `jaxdpd run` and `jaxdpd demo` call.  Output (if a path is given) is an
H5MD file flushed after every chunk, with a checkpoint of the final state, or of the
last good state when the run stops on an error.
"""

import sys
import time
from dataclasses import dataclass, field

import numpy as np

from jaxdpd import driver
from jaxdpd.io.h5md import H5MDWriter
from jaxdpd.observables.chain_correlators import (
    center_of_mass_diffusion,
    chain_correlations,
)
from jaxdpd.observables.chain_series import ideal_references
from jaxdpd.observables.rdf import RadialDistribution
from jaxdpd.observables.rheology import summary_rows
from jaxdpd.simulation import build
from jaxdpd.statistics import block_average


@dataclass
class RunSummary:
    """Measured time series and timings of a run.

    Attributes:
        series: name -> NumPy time series over the production steps.
        rdf: (r, g) or None.
        steps: production steps run.
        wall_seconds: wall time of the production run (compilation included).
        state: the final SimState.
        steady_rate: particle-steps/s after the first chunk (which compiles), or
            NaN for a single-chunk run.
        averages: name -> (mean, standard error) of the scalar series.
        references: name -> exact value of that series for ideal chains (no pair
            forces), shown beside the measured mean.
    """

    series: dict
    rdf: tuple | None
    steps: int
    wall_seconds: float
    state: object = None
    n_particles: int = 0
    steady_rate: float = float("nan")
    averages: dict = field(default_factory=dict)
    references: dict = field(default_factory=dict)

    def table(self) -> str:
        """Mean ± standard error (20 block averages) of each scalar series."""
        rows = [f"{'observable':<30}{'mean':>14}{'± s.e.':>12}{'ideal chain':>14}"]
        for name, (mean, error) in self.averages.items():
            reference = self.references.get(name)
            ideal = f"{reference:>14.6g}" if reference is not None else ""
            rows.append(f"{name:<30}{mean:>14.6g}{error:>12.2g}{ideal}")
        rows.append(f"{'particle-steps/s':<30}{self.steady_rate:>14.4g}{'(compiled)':>12}")
        if self.rdf is not None:
            r, g = self.rdf
            peak = int(np.nanargmax(g))
            rows.append(f"{'g(r) first peak at r':<30}{r[peak]:>14.4g}")
            rows.append(f"{'g(r) first peak height':<30}{g[peak]:>14.4g}")
        return "\n".join(rows)


def _averages(series: dict) -> dict:
    averages = {}
    for name, values in series.items():
        values = np.asarray(values, np.float64)
        if values.ndim == 1 and len(values) >= 40:
            mean, error = block_average(values, n_blocks=20)
            averages[name] = (float(mean), float(error))
        elif values.ndim == 1 and len(values):
            averages[name] = (float(values.mean()), float("nan"))
    tensor = series.get("pressure_tensor")
    if tensor is not None and len(tensor) >= 40:
        for a, b, label in ((0, 1, "P_xy"), (0, 0, "P_xx"), (2, 2, "P_zz")):
            mean, error = block_average(np.asarray(tensor[:, a, b], np.float64), n_blocks=20)
            averages[label] = (float(mean), float(error))
    return averages


class _Progress:
    """A one-line progress bar with steps/s and ETA on a stream."""

    def __init__(self, total: int, stream, enabled: bool):
        self.total, self.stream, self.enabled = total, stream, enabled
        self.start = time.perf_counter()

    def update(self, done: int) -> None:
        if not self.enabled:
            return
        elapsed = time.perf_counter() - self.start
        rate = done / elapsed if elapsed > 0 else 0.0
        eta = (self.total - done) / rate if rate > 0 else float("inf")
        width = 30
        filled = int(width * done / max(1, self.total))
        bar = "#" * filled + "-" * (width - filled)
        self.stream.write(
            f"\r[{bar}] {done}/{self.total} steps  {rate:8.1f} steps/s  ETA {eta:6.1f} s"
        )
        self.stream.flush()

    def finish(self) -> None:
        if self.enabled:
            self.stream.write("\n")
            self.stream.flush()


def simulate(scene, output_path=None, progress: bool = True, stream=sys.stderr) -> RunSummary:
    """Run a scene from its seed (see the module docstring).

    Args:
        scene: a validated Scene.
        output_path: H5MD file to write; defaults to scene.output.path (may be None).
        progress: print a progress bar to `stream`.
    Returns:
        RunSummary.
    Raises:
        SimulationError: the run became invalid (the file holds a checkpoint of the
            last good state).
    """
    simulation = build(scene)
    state = simulation.init_fn()
    chunk = scene.run.chunk
    if scene.run.equilibration:
        state = driver.run(simulation, state, scene.run.equilibration, chunk)
        # Fit the neighbour buffers to the equilibrated configuration: a random
        # start has ideal-gas density fluctuations, a DPD liquid far smaller ones.
        state = simulation.reallocate(state, None)
    state = simulation.init_observers(state)  # correlations of the production run only
    path = output_path if output_path is not None else scene.output.path
    writer = H5MDWriter(path, scene) if path else None
    rdf = None
    if "rdf" in scene.output.observables:
        rdf = RadialDistribution(
            simulation.box, scene.n_particles, scene.output.rdf_max, scene.output.rdf_bins
        )
    collected: dict[str, list] = {}
    bar = _Progress(scene.run.steps, stream, progress)
    first_step = int(state.step)
    every = scene.output.trajectory_every
    chunk_ends = []  # (wall clock, step) after each chunk

    def on_chunk(result: driver.ChunkResult) -> None:
        chunk_ends.append((time.perf_counter(), int(result.state.step)))
        for name, values in result.series.items():
            collected.setdefault(name, []).append(values)
        if rdf is not None:
            rdf.sample(result.state.positions)
        if writer is not None:
            writer.append_observables(result.first_step, scene.integrator.dt, result.series)
            if every and int(result.state.step) % every == 0:
                writer.append_frame(result.state)
            writer.flush()
        bar.update(int(result.state.step) - first_step)

    def on_error(last_good, error) -> None:
        bar.finish()
        if writer is not None:
            writer.write_checkpoint(last_good, reason=str(error))

    start = time.perf_counter()
    try:
        state = driver.run(simulation, state, scene.run.steps, chunk, on_chunk, on_error)
        wall = time.perf_counter() - start
        bar.finish()
        series = {name: np.concatenate(parts) for name, parts in collected.items()}
        rdf_result = rdf.result() if rdf is not None and rdf.samples else None
        correlations = {}
        if state.observers is not None:
            interval = scene.output.correlator_every * scene.integrator.dt
            correlations = chain_correlations(state.observers, interval)
        if writer is not None:
            writer.write_checkpoint(state, reason="end of run")
            if rdf_result is not None:
                writer.write_rdf(*rdf_result, rdf.samples)
            for name, (lag_times, values) in correlations.items():
                writer.write_correlation(name, lag_times, values)
    finally:
        if writer is not None:
            writer.close()
    summary = RunSummary(series, rdf_result, scene.run.steps, wall, state, scene.n_particles)
    if len(chunk_ends) > 1:
        (t0, s0), (t1, s1) = chunk_ends[0], chunk_ends[-1]
        summary.steady_rate = scene.n_particles * (s1 - s0) / (t1 - t0)
    summary.averages = (
        _averages(series) | center_of_mass_diffusion(correlations) | summary_rows(scene, series)
    )
    summary.references = ideal_references(simulation.blocks, scene.solvent.kT)
    return summary
