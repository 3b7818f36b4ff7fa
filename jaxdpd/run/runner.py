"""`simulate(scene)` and `resume(path)`: build, equilibrate, run in chunks, measure,
write, summarise.  This is what `jaxdpd run` and `jaxdpd demo` call.

A run has two phases.  Equilibration runs steps 0 … E (run.equilibration) and
measures nothing; its end fits the neighbour buffers to the equilibrated
configuration.  Production runs steps E … E + S (run.steps): every chunk's series
are appended to the H5MD file (if there is one) and added to running block sums
(jaxdpd.analysis.running_averages), g(r) is sampled at chunk ends, and frames are written
every output.trajectory_every production steps.  Nothing grows in memory with the
run's length.

Checkpoints (jaxdpd.io.checkpoint, a file beside the output replaced atomically)
are written at the end, every output.checkpoint_every steps of either phase, at the
first chunk end after output.checkpoint_seconds of wall time since the last one
(default 300 s, so a long run killed by kill -9 loses minutes, not everything), when
a chunk fails (the last good state), and when SIGINT or SIGTERM arrives (after the
chunk in flight finishes; `RunInterrupted` is then raised).  `resume(path)`
continues from a file's checkpoint: it checks the file against it, drops anything
written after it, replays the stored series into the block sums, and runs on, so the
final state is bit-identical to that of a run that was never interrupted.  A failed
write (full disk, I/O error) raises OutputError and leaves the last checkpoint.
"""

import contextlib
import sys
import time
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

from jaxdpd.analysis.run_summary import ideal_chain_references, table_rows
from jaxdpd.analysis.running_averages import RunningBlockAverages
from jaxdpd.analysis.summary_table import format_table, rdf_rows
from jaxdpd.analysis.temperature_check import temperature_warning
from jaxdpd.engine.build import build
from jaxdpd.io.checkpoint import (
    EQUILIBRATION,
    PRODUCTION,
    checkpoint_path,
    read_checkpoint_info,
)
from jaxdpd.io.errors import RunFileError
from jaxdpd.io.h5md import H5MDWriter, box_edges
from jaxdpd.io.initial import read_initial
from jaxdpd.io.reader import open_run_file, scene_of, time_series_names
from jaxdpd.observables import scene_observables
from jaxdpd.observables.chain_correlators import chain_correlations
from jaxdpd.run import driver
from jaxdpd.run.overwrite import refuse_existing
from jaxdpd.run.progress import Progress
from jaxdpd.run.restore import restore
from jaxdpd.scene import Scene


@dataclass
class RunSummary:
    """Averages and timings of a run.

    Attributes:
        rdf: (r, g) or None.
        steps: production steps of the run (run.steps).
        wall_seconds: wall time of this invocation's production (compilation included).
        state: the final SimState.
        n_particles: N.
        steady_rate: particle-steps/s after the first chunk (which compiles), or NaN
            when fewer than two chunks ran.
        averages: name -> (mean, standard error) of the scalar series over the whole
            production (20 block averages; NaN error for short runs).
        references: name -> exact value of that series for ideal chains (no pair
            forces), shown beside the measured mean.
        series: name -> NumPy series of this invocation's production chunks, only
            with keep_series=True (the file holds them all).
        warnings: name -> message of each average that failed a sanity check
            (jaxdpd.analysis.temperature_check: "temperature" off the set k_BT); marked in the
            table, printed at the end of the run and stored in the file.
    """

    rdf: tuple | None
    steps: int
    wall_seconds: float
    state: object = None
    n_particles: int = 0
    steady_rate: float = float("nan")
    averages: dict = field(default_factory=dict)
    references: dict = field(default_factory=dict)
    series: dict = field(default_factory=dict)
    warnings: dict = field(default_factory=dict)

    def table(self) -> str:
        """Mean ± standard error (20 block averages) and unit of each row
        (jaxdpd.analysis.summary_table); a row that failed a sanity check is marked
        "<- WARNING" and its warning follows the table."""
        extra = {}
        if not np.isnan(self.steady_rate):  # NaN: a single chunk, all compilation
            extra["particle-steps/s"] = (self.steady_rate, "(compiled)")
        if self.rdf is not None:
            extra |= rdf_rows(*self.rdf)
        return format_table(self.averages, self.references, self.warnings, extra)


class Run:
    """A prepared run: a state, where it stands, and what each chunk feeds.

    Made by `prepare` (from a scene) or `prepare_resume` (from a file); `execute()`
    runs it.  Splitting the two lets a caller refuse bad input (which `prepare*`
    raise) before any step runs.

    Args:
        simulation: the built scene.
        state: the state to start from.
        writer: H5MDWriter or None.
        phase: the phase `state` belongs to ("equilibration" or "production").
        progress, stream: progress bar on/off and where it goes (default stderr).
        on_chunk: user hook called with each production ChunkResult after writing.
        keep_series: also keep this invocation's series in memory.
        handle_signals: turn SIGINT/SIGTERM into a checkpointed stop.
    """

    def __init__(
        self,
        simulation,
        state,
        writer=None,
        phase: str = EQUILIBRATION,
        progress: bool = True,
        stream=None,
        on_chunk: Callable | None = None,
        keep_series: bool = False,
        handle_signals: bool = True,
    ):
        scene = simulation.scene
        self.simulation, self.scene, self.state = simulation, scene, state
        self.writer, self.phase = writer, phase
        self.progress, self.stream = progress, stream if stream is not None else sys.stderr
        self.user_hook, self.keep_series = on_chunk, keep_series
        self.handle_signals = handle_signals
        self.averages = RunningBlockAverages(scene.run.steps)
        # Host-side accumulators sampled at production chunk ends (g(r)), by name.
        self.accumulators = {
            component.name: accumulator
            for component in scene_observables(scene)
            if (accumulator := component.chunk_accumulator(simulation)) is not None
        }
        self.series: dict[str, list] = {}
        self.chunk_ends = []  # (wall clock, step) of the first and latest production chunk

    # -- host-side accumulators ------------------------------------------------------
    def extras(self) -> dict:
        """Accumulators stored with a checkpoint (g(r) histogram)."""
        extras = {}
        for accumulator in self.accumulators.values():
            extras.update(accumulator.extras())
        return extras

    def restore_accumulators(self, info) -> None:
        """g(r) from the checkpoint `info` (a CheckpointInfo), after checking that it
        holds exactly the accumulators this scene keeps."""
        expected = set(self.extras())
        if set(info.extras) != expected:
            raise RunFileError(
                f"{info.path}: holds the accumulators {sorted(info.extras)}, this scene "
                f"needs {sorted(expected)} (damaged or edited; g(r) cannot be re-derived)"
            )
        for accumulator in self.accumulators.values():
            accumulator.restore(info.extras)

    def replay(self, info) -> None:
        """Bring the block sums to the checkpoint `info`: the stored series of the
        production so far, read from the reopened file in production chunks (a
        damaged block raises OSError)."""
        start = self.scene.run.equilibration
        done = info.step - start
        if self.phase != PRODUCTION or done <= 0:
            return
        chunk = self.scene.run.chunk
        handle = self.writer.file
        for name in time_series_names(handle):  # in the order written: the table's
            group = handle[f"observables/{name}"]
            steps = group["step"]
            samples = info.series.get(group.name.lstrip("/"), 0)
            if samples != done or steps[0] != start + 1 or steps[samples - 1] != info.step:
                raise RunFileError(
                    f"{self.writer.path}: observables/{name} does not hold steps "
                    f"{start + 1}…{info.step} (the checkpoint's production so far)"
                )
            for first in range(0, done, chunk):
                self.averages.add(first, {name: group["value"][first : first + chunk]})

    # -- the loop --------------------------------------------------------------------
    def checkpoint(self, state, reason: str) -> None:
        if self.writer is not None:
            self.writer.write_checkpoint(state, self.phase, reason, self.extras())
            self.last_checkpoint = time.monotonic()

    def _periodic_checkpoint(self, state, phase_start: int) -> None:
        """A checkpoint every output.checkpoint_every steps, and at the first chunk end
        after output.checkpoint_seconds of wall time since the last one."""
        output = self.scene.output
        every, seconds = output.checkpoint_every, output.checkpoint_seconds
        by_steps = every and (int(state.step) - phase_start) % every == 0
        by_time = seconds and time.monotonic() - self.last_checkpoint >= seconds
        if by_steps or by_time:
            self.checkpoint(state, "periodic")

    def _on_equilibration_chunk(self, result: driver.ChunkResult) -> None:
        self._periodic_checkpoint(result.state, 0)
        self.bar.update(int(result.state.step) - self.start_step, result.series)

    def _on_production_chunk(self, result: driver.ChunkResult) -> None:
        scene, state = self.scene, result.state
        step, start = int(state.step), scene.run.equilibration
        now = (time.perf_counter(), step)
        self.chunk_ends = [self.chunk_ends[0] if self.chunk_ends else now, now]
        self.averages.add(result.first_step - start, result.series)
        if self.keep_series:
            for name, values in result.series.items():
                self.series.setdefault(name, []).append(values)
        for accumulator in self.accumulators.values():
            accumulator.observe(state)
        if self.writer is not None:
            self.writer.append_observables(result.first_step, result.series)
            every = scene.output.trajectory_every
            if every and (step - start) % every == 0:
                bound_box = self.simulation.box.bind(state.box_state)
                self.writer.append_frame(state, box_edges(bound_box))
            self._periodic_checkpoint(state, start)
            self.writer.flush()
        self.bar.update(step - self.start_step, result.series)
        if self.user_hook is not None:
            self.user_hook(result)

    def _on_error(self, last_good, error) -> None:
        self.bar.finish()
        self.checkpoint(last_good, str(error))

    def _advance(self, state, until: int, on_chunk):
        """Run chunks from state.step to step `until`, feeding `on_chunk`."""
        return driver.run(
            self.simulation,
            state,
            until - int(state.step),
            self.scene.run.chunk,
            on_chunk,
            self._on_error,
            self.should_stop,
        )

    def execute(self) -> RunSummary:
        """Run to the end of production, then close the file.

        Raises:
            SimulationError: a chunk failed (the last good state is checkpointed).
            driver.RunInterrupted: SIGINT/SIGTERM arrived (checkpointed after the
                chunk in flight).
            OutputError: writing the file or a checkpoint failed (the last
                checkpoint written before is intact).
        """
        scene, simulation, state = self.scene, self.simulation, self.state
        equilibration = scene.run.equilibration
        end = equilibration + scene.run.steps
        self.start_step = int(state.step)
        self.last_checkpoint = time.monotonic()  # wall clock of the latest checkpoint
        self.bar = Progress(end - self.start_step, self.stream, self.progress)
        guard = driver.SignalGuard() if self.handle_signals else contextlib.nullcontext()
        self.should_stop = guard if self.handle_signals else None
        wall = 0.0
        # The guard spans the final writes too: a second signal then ends the process.
        with guard:
            try:
                if self.phase == EQUILIBRATION:
                    state = self._advance(state, equilibration, self._on_equilibration_chunk)
                    if equilibration:
                        # Fit the neighbour buffers to the equilibrated configuration: a
                        # random start has ideal-gas density fluctuations, a DPD liquid
                        # far smaller ones.
                        state = simulation.reallocate(state, None)
                    # On-device correlators measure the production run only.
                    state = simulation.init_observers(state)
                    self.phase = PRODUCTION
                start = time.perf_counter()
                state = self._advance(state, end, self._on_production_chunk)
                wall = time.perf_counter() - start
                self.bar.finish()
                rdf = self.accumulators.get("rdf")
                rdf = rdf.result() if rdf is not None and rdf.samples else None
                correlations = self._correlations(state)
                warnings = self._sanity_warnings()
                if self.writer is not None:
                    if "temperature" in self.averages.names:
                        self.writer.write_warning("temperature", warnings.get("temperature"))
                    self.checkpoint(state, "end of run")
                    for accumulator in self.accumulators.values():
                        accumulator.write(self.writer)
                    for name, (lag_times, values) in correlations.items():
                        self.writer.write_correlation(name, lag_times, values)
            except driver.RunInterrupted as interrupt:
                self.bar.finish()
                self.checkpoint(interrupt.state, f"interrupted by {interrupt.signal_name}")
                raise
            finally:
                if self.writer is not None:
                    self.writer.close()
        for message in warnings.values():
            print(f"jaxdpd: WARNING: {message}", file=self.stream)
        return self._summary(state, rdf, correlations, wall, warnings)

    def _sanity_warnings(self) -> dict:
        """name -> warning of each average that fails its sanity check (the
        temperature, jaxdpd.analysis.temperature_check)."""
        if "temperature" not in self.averages.names:
            return {}
        mean, error = (float(x) for x in self.averages.result("temperature"))
        message = temperature_warning(self.scene, mean, error)
        return {} if message is None else {"temperature": message}

    def _correlations(self, state) -> dict:
        """name -> (lag times, values) of the on-device chain correlators."""
        if state.observers is None:
            return {}
        interval = self.scene.output.correlator_every * self.scene.step_time
        return chain_correlations(state.observers, interval)

    def _summary(self, state, rdf, correlations, wall: float, warnings: dict) -> RunSummary:
        scene = self.scene
        summary = RunSummary(rdf, scene.run.steps, wall, state, scene.n_particles)
        summary.warnings = warnings
        if len(self.chunk_ends) == 2 and self.chunk_ends[1][1] > self.chunk_ends[0][1]:
            (t0, s0), (t1, s1) = self.chunk_ends
            summary.steady_rate = scene.n_particles * (s1 - s0) / (t1 - t0)
        summary.averages = table_rows(scene, self.averages, correlations)
        summary.references = ideal_chain_references(scene, summary.averages)
        summary.series = {name: np.concatenate(parts) for name, parts in self.series.items()}
        return summary


def prepare(scene, output_path=None, overwrite: bool = False, **options) -> Run:
    """Build a scene, draw its initial state (or read it: [initial]) and create its
    output file.

    Args:
        scene: a validated Scene.
        output_path: H5MD file to write; defaults to scene.output.path (may be None:
            nothing is written and the run cannot be resumed).
        overwrite: replace an existing output file (and its checkpoint); without it an
            existing file is refused (jaxdpd.run.overwrite) before anything is built.
        **options: progress, stream, on_chunk, keep_series, handle_signals (see Run).
    Raises:
        FileExistsError: the output file exists and `overwrite` is False.
        RunFileError: the output file cannot be created.
    """
    path = output_path if output_path is not None else scene.output.path
    if path and not overwrite:
        refuse_existing(path)
    simulation = build(scene)
    state = simulation.init_fn(**read_initial(scene))
    writer = H5MDWriter.create(path, scene, simulation.blocks) if path else None
    return Run(simulation, state, writer, EQUILIBRATION, **options)


def prepare_resume(path, steps: int | None = None, **options) -> Run:
    """Load the run stored in `path` at its checkpoint, to continue in the same file.

    The file is checked against the checkpoint (scene, run identifier, the length
    and last block of every series, the accumulators); anything written after the
    checkpoint (by a run killed before its next one) is dropped, and the stored series
    are replayed into the block sums.

    Args:
        path: an H5MD file written by jaxdpd.
        steps: a new run.steps (production length) to extend a run; at least the
            production steps the checkpoint has done.  None keeps the stored scene's.
        **options: as for `prepare`.
    Raises:
        RunFileError: the file cannot be read back, holds no usable checkpoint, or
            does not hold what its checkpoint counts (damaged, edited, incomplete).
        ValueError: `steps` is shorter than the production already done.
    """
    with open_run_file(path) as handle:
        scene = scene_of(handle)
    info = read_checkpoint_info(path)
    try:
        checkpointed = Scene.from_dict(info.scene).replace(run={"steps": scene.run.steps})
    except (TypeError, ValueError) as error:
        raise RunFileError(f"{info.path}: the scene in its header is invalid ({error})") from None
    if checkpointed != scene:
        raise RunFileError(
            f"{path}: its scene differs from the one its checkpoint "
            f"({checkpoint_path(path)}) was written with, beyond run.steps (edited?)"
        )
    if steps is not None:
        done = info.step - scene.run.equilibration if info.phase == PRODUCTION else 0
        if steps < done:
            raise ValueError(
                f"run.steps = {steps}: the checkpoint in {path} has already done {done} "
                f"production steps; give at least {done}"
            )
        scene = scene.replace(run={"steps": steps})
    simulation, state = restore(path, build(scene))
    run = Run(simulation, state, None, info.phase, **options)
    run.restore_accumulators(info)
    run.writer = H5MDWriter.reopen(path, scene, info)
    try:
        run.replay(info)
    except OSError as error:  # a stored series fails its Fletcher-32 checksum
        run.writer.close()
        raise RunFileError(f"{path}: a stored series is damaged ({error})") from None
    except BaseException:
        run.writer.close()
        raise
    return run


def simulate(scene, output_path=None, progress: bool = True, stream=None, **options):
    """Run a scene from its seed: `prepare(...).execute()`.

    Args:
        scene, output_path: see `prepare` (an existing output file is refused unless
            overwrite=True is passed).
        progress: print a progress bar to `stream` (default sys.stderr).
        **options: overwrite (see `prepare`); on_chunk, keep_series, handle_signals
            (see Run).
    Returns:
        RunSummary.
    Raises:
        SimulationError: the run became invalid (the file holds a checkpoint of the
            last good state).
        driver.RunInterrupted: a signal stopped the run (the file holds a checkpoint).
    """
    return prepare(scene, output_path, progress=progress, stream=stream, **options).execute()


def resume(path, steps: int | None = None, progress: bool = True, stream=None, **options):
    """Continue the run stored in `path`: `prepare_resume(...).execute()`.

    The final state is bit-identical to that of a run never interrupted, and the
    summary averages cover the whole production (the stored part included).
    """
    return prepare_resume(path, steps, progress=progress, stream=stream, **options).execute()
