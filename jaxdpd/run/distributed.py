"""Ensembles over several processes (hosts) on JAX's distributed runtime.

A sweep's B replicas (seeds × flow rates, as `jaxdpd.run.ensemble.replicate` makes
them) are split into contiguous blocks, one per process (`share`).  Every process
replicates and runs only its block, as a batch through the same
`jaxdpd.run.driver.run` as a single-host ensemble (sharded over its local devices;
the same overflow reallocation, error flags, checkpoints and stop requests), and
then every process receives the whole sweep in replica order (`SweepResult`).
Replicas are independent, so the processes exchange nothing while they run; the
only collectives are the final gathers (`multihost_utils.process_allgather`, over
gloo on CPUs, NCCL on GPUs).  A replica's arithmetic does not depend on which
process runs it or on how many replicas share its batch, so the sweep equals the
single-process batch of the same replicas (tests/test_multi_process_ensemble.py).

Files: one H5MD file per replica (`output_dir/replica_0003.h5md`), written only by
the process that owns the replica, so no two processes ever write one file.  Its
header holds the sweep's scene with the replica's seed and flow rate.

Without `initialize` (one process) a sweep is the plain single-host batch.
Launching P local processes: `python -m jaxdpd.run.launch`; several hosts and the
limits: docs/multi_process_ensembles.md.
"""

import argparse
import os
import re
import sys
from dataclasses import dataclass
from pathlib import Path

import jax
import numpy as np
from jax.experimental import multihost_utils

from jaxdpd.engine.build import build
from jaxdpd.geometry.flows import RATE_FIELDS
from jaxdpd.io.checkpoint import PRODUCTION
from jaxdpd.io.h5md import H5MDWriter, box_edges
from jaxdpd.io.initial import read_initial
from jaxdpd.io.layout import EXTENSION
from jaxdpd.run import driver, ensemble
from jaxdpd.scene import Scene

# The environment `python -m jaxdpd.run.launch` gives each process it starts.
COORDINATOR = "JAXDPD_COORDINATOR"
PROCESS_COUNT = "JAXDPD_PROCESS_COUNT"
PROCESS_ID = "JAXDPD_PROCESS_ID"


def initialize(coordinator=None, process_count=None, process_id=None, timeout: int = 300):
    """Join the JAX distributed runtime (once per process, before any other JAX call).

    Args:
        coordinator: "host:port" of process 0's coordination service.
        process_count, process_id: P and this process's index 0 … P − 1.
        timeout: seconds to wait for all processes to join.
    Arguments left out are read from JAXDPD_COORDINATOR, JAXDPD_PROCESS_COUNT and
    JAXDPD_PROCESS_ID (set by `python -m jaxdpd.run.launch`); where those are unset
    too, JAX detects a cluster itself (SLURM, Open MPI, ...).  Cross-process
    collectives on CPUs are gloo's (TCP); GPUs use NCCL.
    """
    environment = os.environ
    coordinator = coordinator or environment.get(COORDINATOR)
    if process_count is None and PROCESS_COUNT in environment:
        process_count = int(environment[PROCESS_COUNT])
    if process_id is None and PROCESS_ID in environment:
        process_id = int(environment[PROCESS_ID])
    jax.config.update("jax_cpu_collectives_implementation", "gloo")
    jax.distributed.initialize(
        coordinator, process_count, process_id, initialization_timeout=timeout
    )


def share(count: int, process: int | None = None, processes: int | None = None) -> range:
    """The replicas a process owns: contiguous blocks, the first count mod P one
    longer (default: this process of jax.process_count())."""
    processes = jax.process_count() if processes is None else processes
    process = jax.process_index() if process is None else process
    base, extra = divmod(count, processes)
    start = process * base + min(process, extra)
    return range(start, start + base + (process < extra))


def allgather(tree) -> list:
    """Every process's `tree` on every process (NumPy leaves), in process order.

    The trees share their structure and leaf ranks, not their shapes (blocks of
    different lengths, neighbour buffers reallocated to different capacities): each
    leaf is padded to the largest shape for the collective and cut back after it.
    """
    leaves, structure = jax.tree.flatten(tree)
    leaves = [np.asarray(leaf) for leaf in leaves]
    if jax.process_count() == 1:
        return [jax.tree.unflatten(structure, leaves)]
    ranks = np.cumsum([0] + [leaf.ndim for leaf in leaves])  # leaf i: dims ranks[i]:ranks[i+1]
    dims = np.array([n for leaf in leaves for n in leaf.shape], np.int32)
    shapes = np.asarray(multihost_utils.process_allgather(dims))  # (P, total rank)
    largest = shapes.max(axis=0)
    padded = [
        np.pad(leaf, [(0, n - m) for n, m in zip(largest[a:b], leaf.shape, strict=True)])
        for leaf, a, b in zip(leaves, ranks[:-1], ranks[1:], strict=True)
    ]
    gathered = multihost_utils.process_allgather(padded)  # each (P, *largest shape)
    trees = []
    for process, shape in enumerate(shapes):
        cut = [
            np.asarray(leaf[process][tuple(slice(0, n) for n in shape[a:b])])
            for leaf, a, b in zip(gathered, ranks[:-1], ranks[1:], strict=True)
        ]
        trees.append(jax.tree.unflatten(structure, cut))
    return trees


class SweepError(RuntimeError):
    """A process's block failed or was stopped; raised on every process, naming each
    process that did not finish (its replicas' files hold their checkpoints)."""


@dataclass
class SweepResult:
    """A whole sweep, on every process, in replica order.

    Attributes:
        states: the B final states (NumPy leaves; neighbour buffers as each process
            left them, so `ensemble.stack(ensemble.common_buffers(...))` makes a batch).
        means: observable name -> (B, ...) mean over the sweep's steps.
        series: observable name -> (B, steps, ...) with keep_series=True, else None.
        owners: (B,) the process that ran each replica.
    """

    states: list
    means: dict
    series: dict | None
    owners: np.ndarray


def replica_path(directory, replica: int) -> Path:
    """The H5MD file of one replica of a sweep."""
    return Path(directory) / f"replica_{replica:04d}{EXTENSION}"


def replica_scene(scene: Scene, seed: int, rate=None) -> Scene:
    """The sweep's scene with one replica's seed and flow rate (its file's header)."""
    if rate is None:
        return scene.replace(seed=int(seed))
    return scene.replace(seed=int(seed), flow={RATE_FIELDS[scene.flow.kind]: float(rate)})


class _ReplicaFiles:
    """The H5MD files of this process's replicas: series every chunk, frames every
    output.trajectory_every steps from the sweep's start, checkpoints."""

    def __init__(self, simulation, directory, replicas, seeds, rates, first_step: int):
        scene = simulation.scene
        self.simulation, self.first_step = simulation, first_step
        Path(directory).mkdir(parents=True, exist_ok=True)
        self.writers = [
            H5MDWriter.create(
                replica_path(directory, k),
                replica_scene(scene, seeds[k], None if rates is None else rates[k]),
                simulation.blocks,
            )
            for k in replicas
        ]

    def append(self, result: driver.ChunkResult) -> None:
        every = self.simulation.scene.output.trajectory_every
        frame = every and (driver.first_step(result.state) - self.first_step) % every == 0
        replicas = ensemble.unstack(result.state) if frame else ()
        for local, writer in enumerate(self.writers):
            writer.append_observables(
                result.first_step, {name: v[local] for name, v in result.series.items()}
            )
            if frame:
                state = replicas[local]
                edges = box_edges(self.simulation.box.bind(state.box_state))
                writer.append_frame(state, edges)
            writer.flush()

    def checkpoint(self, batch, reason: str) -> None:
        for writer, state in zip(self.writers, ensemble.unstack(batch), strict=True):
            writer.write_checkpoint(state, PRODUCTION, reason)

    def close(self) -> None:
        for writer in self.writers:
            writer.close()


def sweep(
    simulation,
    state,
    steps: int,
    chunk: int,
    seeds=None,
    flow_rates=None,
    output_dir=None,
    should_stop=None,
    keep_series: bool = False,
) -> SweepResult:
    """Run replicas of `state` (one per seed and/or flow rate) over all processes.

    Every process calls it with the same arguments; each runs its `share`.

    Args:
        simulation: from jaxdpd.engine.build.build (the same scene everywhere).
        state: the start state of every replica (e.g. an equilibrated one).
        steps, chunk: as for jaxdpd.run.driver.run.
        seeds: B noise seeds; default: the state's seed plus 0, 1, ...
        flow_rates: B rates of the scene's flow (γ̇ or ε̇, 1/time).
        output_dir: directory of the per-replica H5MD files, or None for none.
        should_stop: asked before each chunk (e.g. driver.SignalGuard).
        keep_series: also gather every replica's whole series.
    Raises:
        ValueError: no replicas, seeds and rates of different lengths, or fewer
            replicas than processes.
        SweepError: on every process, when any process's block failed or stopped.
    """
    lengths = {len(values) for values in (seeds, flow_rates) if values is not None}
    if len(lengths) != 1 or 0 in lengths:
        raise ValueError(
            f"sweep: give seeds and/or flow_rates, equally many and at least one ({lengths})"
        )
    (count,) = lengths
    if count < jax.process_count():
        raise ValueError(
            f"sweep: {count} replicas for {jax.process_count()} processes: give at least one "
            "replica per process"
        )
    if seeds is None:
        seeds = [int(state.seed) + k for k in range(count)]
    mine = share(count)
    files, sums, kept = None, {}, {}

    def on_chunk(result: driver.ChunkResult) -> None:
        for name, values in result.series.items():
            sums[name] = sums.get(name, 0) + values.sum(axis=1)
            if keep_series:
                kept.setdefault(name, []).append(values)
        if files is not None:
            files.append(result)

    def on_error(last_good, error) -> None:
        if files is not None:
            files.checkpoint(last_good, str(error))

    # Whatever fails in this process is reported to the others below, so none of
    # them waits in a gather for a process that has given up.
    failure, report = None, ""
    try:
        batch = ensemble.replicate(
            simulation,
            state,
            seeds=[seeds[k] for k in mine],
            flow_rates=None if flow_rates is None else [flow_rates[k] for k in mine],
        )
        if output_dir is not None:
            first = driver.first_step(batch)
            files = _ReplicaFiles(simulation, output_dir, mine, seeds, flow_rates, first)
        batch = driver.run(simulation, batch, steps, chunk, on_chunk, on_error, should_stop)
        if files is not None:
            files.checkpoint(batch, "end of run")
    except driver.RunInterrupted as interrupt:
        failure, report = interrupt, str(interrupt)
        if files is not None:
            files.checkpoint(interrupt.state, str(interrupt))
    except Exception as error:  # SimulationError, OutputError, ...: tell the others
        # The driver numbers a batch's replicas from 0; the sweep's numbers are these.
        message = re.sub(
            r"replica (\d+)", lambda m: f"replica {int(m[1]) + mine.start}", str(error)
        )
        failure, report = error, f"{type(error).__name__}: {message}"
    finally:
        if files is not None:
            files.close()
    _raise_on_failure(report, count, failure)
    local = {
        "batch": batch,
        "means": {name: total / steps for name, total in sums.items()},
        "series": {name: np.concatenate(parts, axis=1) for name, parts in kept.items()},
    }
    blocks = allgather(local)
    return SweepResult(
        states=[state for block in blocks for state in ensemble.unstack(block["batch"])],
        means={name: np.concatenate([b["means"][name] for b in blocks]) for name in sums},
        series={name: np.concatenate([b["series"][name] for b in blocks]) for name in kept}
        if keep_series
        else None,
        owners=np.concatenate([np.full(len(share(count, p)), p) for p in range(len(blocks))]),
    )


def _raise_on_failure(report: str, count: int, failure) -> None:
    """Every process learns what failed where (before any gather that would wait for
    a process that has stopped) and raises the same SweepError."""
    reports = allgather(np.frombuffer(report.encode(), np.uint8))
    failed = [
        f"process {p} (replicas {share(count, p).start}–{share(count, p).stop - 1}): "
        f"{bytes(r).decode()}"
        for p, r in enumerate(reports)
        if len(r)
    ]
    if failed:
        raise SweepError("; ".join(failed)) from failure


def main(argv=None) -> int:
    """`python -m jaxdpd.run.distributed SCENE.toml --seeds 1 2 --flow-rates 0.1 0.5`:
    the sweep seeds × flow rates of a scene (equilibrated once, run.steps each),
    over the processes of `jaxdpd.run.launch`; process 0 prints the means."""
    parser = argparse.ArgumentParser(prog="python -m jaxdpd.run.distributed")
    parser.add_argument("scene", help="scene TOML file")
    parser.add_argument("--seeds", type=int, nargs="+", help="noise seeds")
    parser.add_argument("--flow-rates", type=float, nargs="+", help="rates of [flow]")
    parser.add_argument("-o", "--output-dir", help="directory of the per-replica H5MD files")
    args = parser.parse_args(argv)
    if COORDINATOR in os.environ:
        initialize()
    scene = Scene.from_toml(args.scene)
    simulation = build(scene)
    seeds = args.seeds or [scene.seed]
    rates = args.flow_rates
    grid = [(s, r) for s in seeds for r in (rates or [None])]
    first = simulation.init_fn(**read_initial(scene))
    start = driver.run(simulation, first, scene.run.equilibration, scene.run.chunk)
    start = simulation.init_observers(simulation.reallocate(start, None))
    with driver.SignalGuard() as guard:
        try:
            result = sweep(
                simulation,
                start,
                scene.run.steps,
                scene.run.chunk,
                [s for s, _ in grid],
                None if rates is None else [r for _, r in grid],
                args.output_dir,
                guard,
            )
        except SweepError as error:
            if jax.process_index() == 0:
                print(f"jaxdpd: sweep stopped: {error}", file=sys.stderr)
            return 3
    if jax.process_index() == 0:
        columns = {n: v for n, v in result.means.items() if v.ndim == 1}
        if "pressure_tensor" in result.means:
            columns["P_xy"] = result.means["pressure_tensor"][:, 0, 1]
        print(
            f"{'replica':>8}{'seed':>8}{'rate':>10}{'process':>9}",
            *map("{:>16}".format, columns),
            sep="",
        )
        for k, (seed, rate) in enumerate(grid):
            rate = "" if rate is None else f"{rate:.4g}"
            row = "".join(f"{v[k]:>16.6g}" for v in columns.values())
            print(f"{k:>8}{seed:>8}{rate:>10}{result.owners[k]:>9}{row}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
