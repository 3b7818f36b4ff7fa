"""jaxdpd's MPCD step against a hand-written C step, both against the same bound.

The bound of `solvent_bounds.py` counts XLA's operations of jaxdpd's step at the
machine's multiply-add rate.  Whether 25 % of it is within reach of an MPCD step at all
is a question about the algorithm on this machine, not about XLA: this script answers
it with `mpcd_reference.c`, the same step (streaming with wrap and image counters,
random grid shift, cell ids, per-cell mass and momentum, hashed rotation axes,
Rodrigues rotation, kinetic tensor) written as OpenMP loops that the compiler
vectorises, compiled with `cc -O3 -march=native -fno-trapping-math -fno-math-errno
-fopenmp` (the two flags change no value; without them gcc calls floorf and sqrtf
element by element), on OMP_NUM_THREADS threads (default: one per core).  The C step
is measured against the same number: a fixed yardstick, not a bound on the C code's
own operations.

Both codes run the scene of benchmarks/mpcd_throughput.py (ρ = 10, α = 130°, h = 0.1,
float32, temperature observed) from the same state, in alternating rounds of `steps`
steps.  Each round times a chunk after an untimed one (the first jaxdpd chunk after a
C chunk took 0.71–0.86 ms per step where the next took 0.49–0.64); the rate is the best
round's.  A rate counts only if the code conserved the total momentum and kinetic
energy (an SRD collision conserves both in every cell), and only if one step of each
from the same state gives the same velocities to float32 round-off (the C step draws
the same random grid shift and axes).  Skips, with a message, where no C compiler or
OpenMP is found.

Usage:
    python benchmarks/mpcd_reference.py [--sizes 100000] [--steps 20] [--rounds 15]
        [--output mpcd_reference]
    OMP_NUM_THREADS=1 python benchmarks/mpcd_reference.py --output mpcd_reference_1thread
Writes benchmarks/results/<output>.json.
"""

import argparse
import ctypes
import math
import os
import shutil
import subprocess
import tempfile
import time
from pathlib import Path

import jax
import jax.numpy as jnp
import numpy as np
from _common import compiled_chunk, copy_bandwidth, print_table, write_json
from mpcd_throughput import ANGLE, COLLISION_TIME, solvent_scene
from solvent_bounds import bound_row, cost_per_update, machine_rates

from jaxdpd.engine.build import build

SOURCE = Path(__file__).with_name("mpcd_reference.c")
LOOPS = ("wrap", "cell ids", "scatter", "table sum", "axes", "per-cell table", "rotation")
U = float(np.finfo(np.float32).eps)  # float32 round-off unit of the checks


def compile_reference(directory: Path):
    """(the C step as a ctypes function, its per-loop seconds as a ctypes array), or
    None (with the reason printed)."""
    compiler = os.environ.get("CC", "cc")
    if shutil.which(compiler) is None:
        print(f"skipped: no C compiler ({compiler!r}; set CC)")
        return None
    library = directory / "mpcd_reference.so"
    command = [compiler, "-O3", "-march=native", "-fno-trapping-math", "-fno-math-errno",
               "-fopenmp", "-shared", "-fPIC", "-o", str(library), str(SOURCE), "-lm"]  # fmt: skip
    built = subprocess.run(command, capture_output=True, text=True)
    if built.returncode != 0:
        print(f"skipped: {' '.join(command)} failed:\n{built.stderr}")
        return None
    compiled = ctypes.CDLL(str(library))
    function = compiled.mpcd_steps
    pointer = np.ctypeslib.ndpointer
    function.argtypes = [
        ctypes.c_int, ctypes.c_int, pointer(np.float32, flags="C"),
        pointer(np.float32, flags="C"), pointer(np.int32, flags="C"), ctypes.c_float,
        ctypes.c_float, ctypes.c_float, ctypes.c_uint32, ctypes.c_int, ctypes.c_int,
        pointer(np.float64, flags="C"),
    ]  # fmt: skip
    function.restype = ctypes.c_int
    return function, (ctypes.c_double * len(LOOPS)).in_dll(compiled, "mpcd_loop_seconds")


def reference_arguments(scene, state) -> tuple:
    """The C step's leading arguments for `state`: sizes, writable float32/int32 copies
    of positions, velocities and image counters (the C step updates them in place), h,
    cos α, sin α and the seed."""
    angle = math.radians(ANGLE)
    return (
        scene.n_particles,
        round(scene.box.lengths[0]),
        np.array(state.positions, np.float32),
        np.array(state.velocities, np.float32),
        np.array(state.image, np.int32),
        COLLISION_TIME,
        math.cos(angle),
        math.sin(angle),
        int(state.seed),
    )


def conserved(velocities) -> tuple[np.ndarray, float]:
    """(total momentum, twice the kinetic energy) in float64, unit masses."""
    v = np.asarray(velocities, np.float64)
    return v.sum(axis=0), float(np.sum(v * v))


def check_conservation(code: str, before, after, steps: int) -> None:
    """Raise unless `code` kept the momentum and the kinetic energy finite and within
    float32 round-off accumulated over the run.

    Each step rounds every velocity by about u |v| independently, so the total momentum
    wanders by about u √(steps · 2E₀) (2E₀ = Σ v²); the rotation keeps |v| only to about
    u, so the energy may drift by about u · 2E₀ a step.  The bounds are ten times these
    (measured drifts over 600 steps: 8 and 20 times below them).
    """
    (p0, e0), (p1, e1) = before, after
    momentum_ok = np.max(np.abs(p1 - p0)) <= 10 * U * math.sqrt(steps * e0)
    energy_ok = abs(e1 - e0) <= 10 * U * steps * e0
    if not (momentum_ok and energy_ok):  # also when any of them is NaN
        raise RuntimeError(f"{code}: momentum or energy not conserved: {p0}→{p1}, {e0}→{e1}")


def check_same_step(scene, state, reference) -> float:
    """The largest velocity difference after one step of each code from `state`.

    The C step draws the same grid shift and rotation axes (the same hash of the same
    keys), so the two agree to float32 round-off; a wrong cell, axis or rotation would
    differ by O(1).  Raises unless the velocities agree within 10⁻⁴ (measured: about
    10⁻⁶), the positions within 10⁻⁴ (measured: equal), the image counters exactly and
    the kinetic tensors within 2 √N u of their largest entry (two float32 sums of N
    terms in different orders; measured: 2.4·10⁻⁶ relative at N = 106 480).
    """
    one_step, _ = compiled_chunk(scene, state, 1)
    after, samples = one_step(state)
    arguments = reference_arguments(scene, state)
    positions, velocities, image = arguments[2:5]
    kinetic = np.zeros((1, 6))
    status = reference(*arguments, int(state.step), 1, kinetic)
    difference = float(np.max(np.abs(np.asarray(after.velocities) - velocities)))
    moved = float(np.max(np.abs(np.asarray(after.positions) - positions)))
    jax_kinetic = np.asarray(samples["kinetic"][-1], np.float64)
    c_kinetic = kinetic[0][[[0, 3, 4], [3, 1, 5], [4, 5, 2]]]
    scale = np.max(np.abs(jax_kinetic))
    kinetic_error = float(np.max(np.abs(c_kinetic - jax_kinetic)) / scale)
    agree = (
        status == 0
        and difference < 1e-4
        and moved < 1e-4
        and np.array_equal(np.asarray(after.image), image)
        and kinetic_error < 2 * math.sqrt(scene.n_particles) * U
    )
    if not agree:
        raise RuntimeError(
            f"the C step differs from jaxdpd's: velocities by {difference}, positions by "
            f"{moved}, kinetic tensor by {kinetic_error} of its scale, images equal "
            f"{np.array_equal(np.asarray(after.image), image)} (status {status})"
        )
    return difference


def measure(n: int, steps: int, rounds: int, compiled, rates: dict) -> list[dict]:
    reference, loop_seconds = compiled
    scene = solvent_scene(n, "float32")
    chunk, state = compiled_chunk(scene, None, steps)
    state, _ = chunk(state)
    difference = check_same_step(scene, state, reference)
    count = scene.n_particles
    arguments = reference_arguments(scene, state)
    velocities = arguments[3]
    kinetic = np.zeros((steps, 6))
    start = conserved(velocities)
    jax_start = conserved(state.velocities)
    progress = {"state": state, "samples": None, "first": int(state.step)}

    def run_jaxdpd():
        progress["state"], progress["samples"] = chunk(progress["state"])
        jax.block_until_ready(progress["state"])

    def run_reference():
        if reference(*arguments, progress["first"], steps, kinetic) != 0:
            raise MemoryError("the C reference could not allocate its tables")
        progress["first"] += steps

    seconds = {"jaxdpd": [], "C reference": []}
    loop_seconds[:] = [0.0] * len(LOOPS)
    runs = {"jaxdpd": run_jaxdpd, "C reference": run_reference}
    for _ in range(rounds):
        for code, run in runs.items():
            run()  # warm: the first chunk after the other code's is slower
            begin = time.perf_counter()
            run()
            seconds[code].append(time.perf_counter() - begin)
    state, samples = progress["state"], progress["samples"]
    steps_run = 2 * rounds * steps  # by each code: a warm and a timed chunk per round
    loop_ns = {
        name: 1e9 * seconds_spent / (steps_run * count)
        for name, seconds_spent in zip(LOOPS, loop_seconds, strict=True)
    }
    if int(state.flags):
        raise RuntimeError(f"jaxdpd run flagged errors {int(state.flags)}")
    check_conservation("jaxdpd", jax_start, conserved(state.velocities), steps_run)
    check_conservation("C reference", start, conserved(velocities), steps_run)
    cost = cost_per_update(jax.jit(build(scene).step_fn).lower(state).compile(), count)
    machine = {"bandwidth": copy_bandwidth((count, 6), jnp.float32, steps), **rates}
    temperatures = {
        "jaxdpd": float(np.trace(np.asarray(samples["kinetic"])[-1]) / (3 * (count - 1))),
        "C reference": float(np.sum(kinetic[-1, :3]) / (3 * (count - 1))),
    }
    rows = []
    for code, times in seconds.items():
        row = bound_row(code, count, "float32", count * steps / min(times), 48, cost, machine)
        rows.append(row | {"temperature": temperatures[code], "rounds": rounds,
                           "one_step_velocity_difference": difference})  # fmt: skip
    for row in rows:
        row["ratio_to_jaxdpd"] = row["rate_per_s"] / rows[0]["rate_per_s"]
    # The bound is jaxdpd's (XLA's count of jaxdpd's step); XLA's counts describe no C.
    for key in ("xla_bytes", "xla_flops", "xla_transc", "xla_memory_bound", "fraction_xla_bytes"):
        del rows[1][key]
    rows[1]["loop_ns_per_particle"] = loop_ns
    return rows


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sizes", type=int, nargs="+", default=[100_000])
    parser.add_argument("--steps", type=int, default=20)
    parser.add_argument("--rounds", type=int, default=15)
    parser.add_argument("--output", default="mpcd_reference", help="results file name")
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as directory:
        compiled = compile_reference(Path(directory))
        if compiled is None:
            return
        rates = machine_rates(jnp.float32)
        rows = [
            row for n in args.sizes for row in measure(n, args.steps, args.rounds, compiled, rates)
        ]
    columns = ["method", "N", "rate_per_s", "xla_flops", "compute_bound", "binding",
               "fraction", "temperature", "ratio_to_jaxdpd"]  # fmt: skip
    print_table(columns, rows)
    loops = [{"N": row["N"], **row["loop_ns_per_particle"]} for row in rows[1::2]]
    print(
        "C reference, ns per particle-step in each loop (thread 0's wall time, its waits "
        "at the loop's barrier included; means over every call, untimed ones too):"
    )
    print_table(["N", *LOOPS], loops)
    threads = os.environ.get("OMP_NUM_THREADS", str(os.cpu_count()))
    print(f"wrote {write_json(args.output, {'omp_threads': threads, 'rows': rows})}")


if __name__ == "__main__":
    main()
