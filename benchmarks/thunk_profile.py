"""Where a compiled computation's time goes: wall time per XLA operation.

XLA's CPU runtime records every operation it executes (a fusion, a sort, a
scatter, a YNNPACK call) in JAX's profiler trace, and on a GPU the trace holds each
kernel's device time per stream.  `thunk_times` runs a callable under
`jax.profiler.trace` and sums those records by operation name, so the
optimised program's costly fusions can be found by name in its HLO text
(`jax.jit(f).lower(...).compile().as_text()`).  The times carry the profiler's own
overhead (a few µs per operation) and the machine's load; a conditional's or a
loop's record includes the operations of its branches or body, which are listed too.
On two or more cores XLA runs independent operations at once and splits large
fusions over threads, so an operation's record also holds the time it waited for
a thread: a fusion can look costly while the step would not miss it.  Profile
on one core (`taskset -c 0 python ...`) to see what each operation computes.

Usage (the DPD fluid's step at N = 3000, 100 steps; prints the top operations;
`--hlo PATH` also writes the profiled chunk's optimised HLO, to look the names up):
    python benchmarks/thunk_profile.py --size 3000 --steps 100 --top 30
    python benchmarks/thunk_profile.py --size 1000000 --steps 20    # on a GPU
"""

import argparse
import collections
import re
import tempfile
from pathlib import Path

import jax
from jax.profiler import ProfileData

WRAPPERS = ("ThunkExecutor", "PjitFunction", "CommonPjRt")


def thunk_times(function, *args) -> collections.Counter:
    """{operation name: total µs} of one call of `function(*args)` (blocked on): the
    CPU runtime's operation records, or on a GPU the device time of its kernels."""
    with tempfile.TemporaryDirectory() as directory:
        with jax.profiler.trace(directory):
            jax.block_until_ready(function(*args))
        planes = ProfileData.from_file(str(next(Path(directory).rglob("*.xplane.pb")))).planes
    on_gpu = jax.default_backend() == "gpu"
    totals = collections.Counter()
    for plane in planes:
        if ("GPU" in plane.name) != on_gpu:
            continue
        for line in plane.lines:
            if line.name == "python":  # the host's Python calls
                continue
            for event in line.events:
                if not event.name.startswith(WRAPPERS):
                    totals[event.name] += event.duration_ns / 1e3
    return totals


def by_kind(totals: collections.Counter) -> collections.Counter:
    """The same times summed over numbered copies (`wrapped_scatter.4` →
    `wrapped_scatter`)."""
    kinds = collections.Counter()
    for name, microseconds in totals.items():
        kinds[re.sub(r"[.\d]+$", "", name)] += microseconds
    return kinds


def report(totals: collections.Counter, steps: int, top: int) -> None:
    """Print the total and the `top` costliest operations and kinds, in ms per step
    of a profiled call that ran `steps` steps."""
    per_step = 1e-3 / steps
    operations = sum(v for k, v in totals.items() if not k.startswith("while"))
    print(f"{operations * per_step:.3f} ms per step in operations")
    for title, table in (("by operation", totals), ("by kind", by_kind(totals))):
        print(f"\n{title} (ms per step)")
        for name, microseconds in table.most_common(top):
            print(f"{microseconds * per_step:8.3f}  {name}")


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--size", type=int, default=3000)
    parser.add_argument("--steps", type=int, default=100)
    parser.add_argument("--top", type=int, default=30)
    parser.add_argument("--hlo", type=Path, default=None, help="write the optimised HLO")
    args = parser.parse_args()

    from dpd_throughput import equilibrated_fluid

    from jaxdpd.run import driver

    simulation, state = equilibrated_fluid(args.size)
    state = driver.run(simulation, state, args.steps, args.steps)  # compiled, fitted
    totals = thunk_times(lambda s: driver.run(simulation, s, args.steps, args.steps), state)
    print(f"N = {args.size}:", end=" ")
    report(totals, args.steps, args.top)
    if args.hlo:
        chunk = driver._scan_chunk.lower(simulation.step_fn, state, args.steps).compile()
        args.hlo.write_text(chunk.as_text())


if __name__ == "__main__":
    main()
