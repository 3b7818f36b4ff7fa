"""Device time per compiled kernel of a DPD chunk, from a JAX profiler trace.

The fluid of `dpd_throughput.py` (float32), equilibrated by the driver and run once
more through `driver.run`, so that its buffers are refitted as on the path users run;
then one jitted chunk of `--steps` steps is traced (`jax.profiler.trace`) and the
events of the device's planes (the GPU's streams; on a CPU the XLA thread pools) are
summed per kernel name. The table lists the costliest kernels: total time, calls,
and the line (stream or thread) they ran on. Kernel names are XLA's fusion names,
which `XLA_FLAGS=--xla_dump_to=DIR --xla_dump_hlo_as_text` ties to the optimised
program.

Usage:
    python benchmarks/kernel_profile.py [--size 1000000] [--steps 20] [--top 30]
"""

import argparse
import collections
import glob
import tempfile
import time

import jax
from dpd_throughput import equilibrated_fluid
from jax.profiler import ProfileData

from jaxdpd.run import driver


def kernel_times(trace_directory: str, device_planes: bool) -> collections.Counter:
    """{(line name, event name): [total ns, calls]} over the trace's planes (only
    those named for a GPU when `device_planes`), leaving out the host's Python calls
    and the CPU runtime's wrappers around its kernels."""
    path = glob.glob(f"{trace_directory}/**/*.xplane.pb", recursive=True)[0]
    totals = collections.defaultdict(lambda: [0, 0])
    for plane in ProfileData.from_file(path).planes:
        if device_planes and "GPU" not in plane.name:
            continue
        for line in plane.lines:
            if line.name == "python":  # the host's Python calls, on a CPU's plane
                continue
            for event in line.events:
                if event.name.startswith("ThunkExecutor"):  # wraps a CPU's kernels
                    continue
                entry = totals[(line.name, event.name)]
                entry[0] += event.duration_ns
                entry[1] += 1
    return totals


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--size", type=int, default=1_000_000)
    parser.add_argument("--steps", type=int, default=20)
    parser.add_argument("--top", type=int, default=30)
    args = parser.parse_args()
    simulation, state = equilibrated_fluid(args.size)
    state = driver.run(simulation, state, args.steps, args.steps)  # refits the buffers
    chunk = jax.jit(lambda s: driver._scan_chunk(simulation.step_fn, s, args.steps))
    jax.block_until_ready(chunk(state))
    start = time.perf_counter()
    jax.block_until_ready(chunk(state))
    wall = time.perf_counter() - start
    print(
        f"N = {args.size}, {args.steps} steps: {wall * 1e3:.1f} ms, "
        f"{args.size * args.steps / wall:.3e} particle-steps/s ({jax.devices()[0].device_kind})"
    )
    with tempfile.TemporaryDirectory() as directory:
        with jax.profiler.trace(directory):
            jax.block_until_ready(chunk(state))
        totals = kernel_times(directory, jax.default_backend() != "cpu")
    ranked = sorted(totals.items(), key=lambda item: -item[1][0])[: args.top]
    print(f"{'ms':>9} {'calls':>6}  line: kernel")
    for (line, name), (nanoseconds, calls) in ranked:
        print(f"{nanoseconds / 1e6:9.3f} {calls:6d}  {line[:24]}: {name[:100]}")


if __name__ == "__main__":
    jax.config.update("jax_enable_x64", True)
    main()
