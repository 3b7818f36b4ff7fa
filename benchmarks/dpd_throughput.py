"""Throughput of a Groot–Warren DPD fluid: particle-steps per second against N.

System: ρ = 3, a = 25, γ = 4.5 (σ = 3), k_BT = 1, Δt = 0.04, λ = 0.5, cell-list
neighbours rebuilt every step.  Compilation time (the first chunk's wall time,
initial state included, minus the best timed chunk's) is reported separately from
the stepping rate, which is the best of several chunks, each one call of
`driver.run` as a user makes it (error checks and buffer refits included), after
an equilibration run the same way (each size runs in its own process).

The peak resident set size is reported with the bytes XLA's compiled chunk needs
(arguments, outputs and temporaries, from `memory_analysis()`), which is the
per-particle memory proper: the process RSS also holds the JAX runtime and compiler.
With `--peer lammps` the same sizes then run alternately with LAMMPS
(`benchmarks/peer_lammps.py`, float32 jaxdpd; skipped with a message where LAMMPS is
absent).

Usage:
    python benchmarks/dpd_throughput.py [--sizes 3000 24000 96000]
        [--precisions float32 float64] [--steps 100] [--skin 0] [--peer lammps]
        [--output dpd_throughput]
Writes benchmarks/results/<output>.json.
"""

import argparse
import multiprocessing
import time

import jax
import numpy as np
from _common import peak_rss_mib, print_table, write_json

from jaxdpd.analysis.statistics import block_average
from jaxdpd.engine.build import build
from jaxdpd.run import driver
from jaxdpd.scene import Scene

DENSITY, REPULSION, GAMMA, DT = 3.0, 25.0, 4.5, 0.04


def fluid_scene(
    n: int, precision: str, observables=("temperature", "pressure"), skin: float = 0.0
) -> Scene:
    return Scene.from_dict(
        {
            "seed": 1,
            "precision": precision,
            "particles": {"density": DENSITY, "count": n},
            "solvent": {"method": "dpd", "kT": 1.0, "gamma": GAMMA},
            "pair": {"a": REPULSION},
            "neighbors": {"skin": skin},
            "integrator": {"dt": DT, "lambda": 0.5},
            "output": {"observables": list(observables)},
        }
    )


def equilibrated_fluid(
    n: int, observables=("temperature", "pressure"), equilibration=200, chunk=100
):
    """(simulation, state) of the float32 fluid after `equilibration` steps of the
    driver (which refits the neighbour buffers once the random start has relaxed)."""
    simulation = build(fluid_scene(n, "float32", observables))
    return simulation, driver.run(simulation, simulation.init_fn(), equilibration, chunk)


class JaxdpdFluid:
    """The fluid on the path users run: `build`, `init_fn`, then `driver.run` called
    once per timed chunk (its error checks, buffer refits and host-side series
    included), after `equilibration` steps run the same way."""

    def __init__(self, n: int, precision: str, steps: int, equilibration: int, skin: float = 0.0):
        self.scene = fluid_scene(n, precision, skin=skin)
        self.n, self.steps = n, steps
        self.simulation = build(self.scene)
        start = time.perf_counter()
        self.state = self.simulation.init_fn()
        self.run_chunk()  # compiles the chunk at the random start's buffers
        # Initial state, compilation and one chunk; `measure` subtracts a chunk.
        self.first_chunk_seconds = time.perf_counter() - start
        self.state = driver.run(self.simulation, self.state, equilibration, steps)
        self.run_chunk()  # compiles again if the driver refitted the buffers
        # The bytes XLA's compiled chunk needs (measurement only; not what is timed).
        self.compiled = driver._scan_chunk.lower(
            self.simulation.step_fn, self.state, steps
        ).compile()
        memory = self.compiled.memory_analysis()
        self.chunk_bytes = (
            memory.argument_size_in_bytes
            + memory.output_size_in_bytes
            + memory.temp_size_in_bytes
            - memory.alias_size_in_bytes
        )

    def run_chunk(self) -> tuple[float, dict]:
        """Advance one chunk with `driver.run`; (wall seconds, {"temperature",
        "pressure"} per step)."""
        chunks = []
        start = time.perf_counter()
        self.state = driver.run(self.simulation, self.state, self.steps, self.steps, chunks.append)
        seconds = time.perf_counter() - start
        series = chunks[0].series
        return seconds, {key: series[key] for key in ("temperature", "pressure")}


def measure(
    n: int, precision: str, steps: int, equilibration: int, chunks: int, skin: float = 0.0
) -> dict:
    """Throughput (best chunk), memory and thermodynamics of one fluid."""
    fluid = JaxdpdFluid(n, precision, steps, equilibration, skin)
    seconds = []
    series = {"temperature": [], "pressure": []}
    for _ in range(chunks):
        elapsed, chunk_series = fluid.run_chunk()
        seconds.append(elapsed)
        for key, values in chunk_series.items():
            series[key].append(values)
    rate = n * steps / min(seconds)
    row = {
        "N": n,
        "precision": precision,
        "skin": skin,
        "particle_steps_per_s": rate,
        "ns_per_particle_step": 1e9 / rate,
        "compile_s": fluid.first_chunk_seconds - min(seconds),
        "chunk_bytes_per_particle": fluid.chunk_bytes / n,
        "peak_rss_mib": peak_rss_mib(),
    }
    for key, values in series.items():
        mean, error = block_average(np.concatenate(values), n_blocks=10)
        row[key], row[f"{key}_error"] = float(mean), float(error)
    return row


def measure_in_child(arguments) -> dict:
    """`measure` in a fresh process, so that its peak RSS is this fluid's alone."""
    with multiprocessing.get_context("spawn").Pool(1) as pool:
        return pool.apply(_measure_x64, arguments)


def _measure_x64(*arguments) -> dict:
    jax.config.update("jax_enable_x64", True)
    return measure(*arguments)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sizes", type=int, nargs="+", default=[3000, 24000, 96000])
    parser.add_argument("--precisions", nargs="+", default=["float32", "float64"])
    parser.add_argument("--steps", type=int, default=100)
    parser.add_argument("--chunks", type=int, default=3, help="timed chunks (best counts)")
    parser.add_argument("--equilibration", type=int, default=200)
    parser.add_argument("--skin", type=float, default=0.0, help="Verlet skin of the cell list")
    parser.add_argument("--output", default="dpd_throughput", help="results file name")
    parser.add_argument("--peer", choices=["lammps"], default=None)
    args = parser.parse_args()
    rows = []
    for precision in args.precisions:
        for n in args.sizes:
            row = measure_in_child(
                (n, precision, args.steps, args.equilibration, args.chunks, args.skin)
            )
            row["rss_kib_per_particle"] = row["peak_rss_mib"] * 1024 / n
            rows.append(row)
            print_table(list(row), [row])
        same = [row for row in rows if row["precision"] == precision]
        costs = [row["ns_per_particle_step"] for row in same]
        for row in same:
            row["cost_relative_to_smallest_N"] = row["ns_per_particle_step"] / costs[0]
    columns = [
        "N",
        "precision",
        "particle_steps_per_s",
        "ns_per_particle_step",
        "cost_relative_to_smallest_N",
        "chunk_bytes_per_particle",
        "rss_kib_per_particle",
        "compile_s",
        "temperature",
        "pressure",
    ]
    print()
    print_table(columns, rows)
    path = write_json(args.output, {"steps": args.steps, "rows": rows})
    print(f"wrote {path}")
    if args.peer == "lammps":
        from peer_lammps import run_comparison  # imports this module: import late

        run_comparison(args.sizes, steps=args.steps, equilibration=args.equilibration)


if __name__ == "__main__":
    jax.config.update("jax_enable_x64", True)
    main()
