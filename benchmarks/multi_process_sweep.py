"""Wall time of one ensemble sweep run by P processes of this machine
(jaxdpd.run.distributed over jaxdpd.run.launch), P = 1 and 2 by default.

The sweep: B replicas (seeds × shear rates) of a sheared Groot–Warren DPD fluid
(ρ = 3, a = 25, γ = 4.5, Δt = 0.04, λ = 0.65, float32, Lees–Edwards box, N
particles), `steps` steps in chunks.  Each process runs its block of B/P replicas
as one vmapped batch on its one CPU device.  Per P, process 0 reports:

- first_s: the first sweep of one chunk (compilation of the block's program,
  replication, the gathers' programs);
- sweep_s: the timed sweep of `steps` steps after it (run and gather), the figure
  to compare;
- launch_s: the launcher's whole wall time (interpreter and JAX start-up, runtime
  join, both sweeps), and cpu_s the processor time its processes used (cpu_s /
  launch_s > 1: more than one core busy on average).

On a machine with fewer cores than P × the cores XLA uses per process the
processes compete for them, and other work on the machine changes the figures: the
load average before each launch is recorded, and the P are measured in `--rounds`
rounds, each in the reverse order of the one before.

Usage:
    python benchmarks/multi_process_sweep.py [--processes 1 2] [--rounds 2]
        [--particles 3000] [--replicas 8] [--steps 200] [--chunk 50]
Writes benchmarks/results/multi_process_sweep.json.
"""

import argparse
import json
import os
import resource
import subprocess
import sys
import time
from pathlib import Path

from _common import print_table, write_json

from jaxdpd.run import launch

PROCESS = """
import json, sys, time
from jaxdpd.run import distributed
distributed.initialize()
import jax, numpy as np
sys.path.insert(0, {benchmarks!r})
from sweep_cost import sheared_fluid
from jaxdpd.engine.build import build
particles, replicas, steps, chunk = {particles}, {replicas}, {steps}, {chunk}
simulation = build(sheared_fluid(particles))
start = simulation.init_fn()
seeds = [100 + k for k in range(replicas)]
rates = list(np.linspace(0.05, 0.5, replicas))
begin = time.perf_counter()
distributed.sweep(simulation, start, chunk, chunk, seeds, rates)
first = time.perf_counter() - begin
begin = time.perf_counter()
result = distributed.sweep(simulation, start, steps, chunk, seeds, rates)
seconds = time.perf_counter() - begin
if jax.process_index() == 0:
    print("RESULT", json.dumps({{"first_s": first, "sweep_s": seconds}}))
"""


def measure(processes: int, args) -> dict:
    """Launch one P; process 0's figures and the launch's."""
    benchmarks = str(Path(__file__).resolve().parent)
    code = PROCESS.format(benchmarks=benchmarks, **vars(args) | {"processes": processes})
    load = os.getloadavg()[0]
    used = resource.getrusage(resource.RUSAGE_CHILDREN)
    begin = time.perf_counter()
    children = launch.launch(
        [sys.executable, "-c", code], processes, stdout=subprocess.PIPE, text=True
    )
    outputs = [child.communicate()[0] for child in children]
    launch_seconds = time.perf_counter() - begin
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    cpu_seconds = after.ru_utime + after.ru_stime - used.ru_utime - used.ru_stime
    if any(child.returncode for child in children):
        raise SystemExit(f"P = {processes}: a process failed")
    (line,) = [row for row in outputs[0].splitlines() if row.startswith("RESULT")]
    figures = json.loads(line.split(" ", 1)[1])
    particle_steps = args.replicas * args.particles * args.steps
    return {
        "P": processes,
        "B": args.replicas,
        "N": args.particles,
        "steps": args.steps,
        **figures,
        "launch_s": launch_seconds,
        "cpu_s": cpu_seconds,
        "particle_steps_per_s": particle_steps / figures["sweep_s"],
        "load_before": load,
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--processes", type=int, nargs="+", default=[1, 2])
    parser.add_argument("--rounds", type=int, default=2)
    parser.add_argument("--particles", type=int, default=3000)
    parser.add_argument("--replicas", type=int, default=8)
    parser.add_argument("--steps", type=int, default=200)
    parser.add_argument("--chunk", type=int, default=50)
    args = parser.parse_args()
    rows = []
    for round_ in range(args.rounds):
        order = args.processes if round_ % 2 == 0 else args.processes[::-1]
        rows.extend({"round": round_, **measure(p, args)} for p in order)
    print_table(list(rows[0]), rows)
    path = write_json("multi_process_sweep", {"rows": rows})
    print(f"wrote {path}")


if __name__ == "__main__":
    main()
