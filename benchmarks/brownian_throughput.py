"""Brownian-dynamics throughput and pathwise-gradient memory (issue 4, must show 6).

1. Dumbbell-steps per second of the FENE (b = 50) semi-implicit predictor–corrector in
   shear (De = 1), float64, for 1e3 ... 1e6 dumbbells: jaxdpd (jitted ``simulate``)
   against a plain NumPy implementation of the same scheme (same predictor, corrector
   and cubic root; NumPy's own generators) timed in the same run; both with Gaussian
   and with three-point increments.  JAX timings exclude compilation (reported
   separately); each figure is the best of ``--repeats`` runs.  Beside it, the
   fraction of the memory bound: a step must read and write each connector (6
   float64 values), and the copy bandwidth B of that much data is measured in the
   same run (benchmarks/_common.copy_bandwidth): bound = B / 48 dumbbell-steps/s.
2. Memory of the reverse-mode pathwise gradient d<f Q_x Q_y>/db against trajectory
   length, with and without ``jax.checkpoint`` (segments of sqrt(n) steps): XLA's
   compiled temporary-buffer size (``compiled.memory_analysis()``), and the measured
   wall time of the gradient where it fits in memory.  Forward mode (jvp) for reference.

Prints a table and writes ``benchmarks/results/brownian_throughput.json``.

    python benchmarks/brownian_throughput.py            # full (~5 min on 2 cores)
    python benchmarks/brownian_throughput.py --quick    # smoke run
"""

from __future__ import annotations

import argparse
import json
import math
import os
import platform
import time
from pathlib import Path

import jax
import jax.numpy as jnp
import numpy as np
from _common import best_of, copy_bandwidth

import jaxdpd
from jaxdpd.brownian import (
    FENE,
    simulate,
    state_from_connectors,
    stationary_average,
    velocity_gradient,
)

B, DE, DT = 50.0, 1.0, 0.01
RESULTS = Path(__file__).resolve().parent / "results" / "brownian_throughput.json"


# ----------------------------------------------------------------------------- NumPy
def numpy_fene_length(r, h, b):
    """Middle root of l^3 - R l^2 - b(1+h) l + b R = 0, as FENE.implicit_length."""
    sqrt_b = math.sqrt(b)
    rho = r / sqrt_b
    l_small = r / (1 + h)
    for _ in range(4):
        l_small = r / (1 + h / (1 - l_small * l_small / b))
    p = -b * (1 + h) - r * r / 3
    q = -2 * r**3 / 27 + b * r * (2 - h) / 3
    m = 2 * np.sqrt(-p / 3)
    cos_arg = np.clip(3 * q / (p * m), -1, 1)
    l_trig = m * np.cos(np.arccos(cos_arg) / 3 - 2 * math.pi / 3) + r / 3
    big = rho > 2
    r_big = np.where(big, r, 3 * sqrt_b)
    u = np.minimum(h * sqrt_b / (r_big - sqrt_b), 1 - 1e-4)
    for _ in range(4):
        s = np.sqrt(1 - u)
        length_u = sqrt_b * s
        k = u * (r_big - length_u) - h * length_u
        dk = r_big - length_u + (u + h) * sqrt_b / (2 * s)
        u = np.clip(u - k / dk, 0, 1 - 1e-4)
    l_big = sqrt_b * np.sqrt(1 - u)
    root = np.where(rho < 1e-2, l_small, np.where(big, l_big, l_trig))
    resid = (root - r) * (root * root - b) - b * h * root
    slope = (root * root - b) + 2 * root * (root - r) - b * h
    length = root - resid / slope
    return np.clip(length, 0, sqrt_b * (1 - 4 * np.finfo(np.float64).eps))


def numpy_step(q, dw, kappa, b, dt):
    """One Öttinger predictor–corrector step for (N, 3) connectors (dynamics.py)."""
    f = 1 / (1 - np.einsum("ij,ij->i", q, q) / b)
    flow = q @ kappa.T
    q_pred = q + (flow - 0.5 * f[:, None] * q) * dt + dw
    rhs = q + 0.5 * dt * (flow + q_pred @ kappa.T) - 0.25 * dt * f[:, None] * q + dw
    r = np.sqrt(np.einsum("ij,ij->i", rhs, rhs))
    h = 0.25 * dt
    length = numpy_fene_length(r, h, b)
    scale = np.where(r > 0, length / np.where(r > 0, r, 1), 1 / (1 + h))
    return rhs * scale[:, None]


def numpy_run(q, n_steps, noise, rng):
    kappa = np.asarray(velocity_gradient("shear", DE))
    for _ in range(n_steps):  # the NumPy reference loops in Python, one array op each
        if noise == "gaussian":
            dw = math.sqrt(DT) * rng.standard_normal(q.shape)
        else:
            dw = math.sqrt(3 * DT) * (rng.integers(0, 6, q.shape) == 5) - math.sqrt(3 * DT) * (
                rng.integers(0, 6, q.shape) == 0
            )
        q = numpy_step(q, dw, kappa, B, DT)
    return q


# ------------------------------------------------------------------------------- JAX
def jax_runner(n, n_steps, noise):
    kappa = velocity_gradient("shear", DE)
    spring = FENE(B)

    @jax.jit
    def run(key, q0):
        state = state_from_connectors(q0, spring)
        final, _ = simulate(
            key, state, kappa, spring, DT, n_samples=1, sample_every=n_steps,
            observe=lambda c, s: None, noise=noise,
        )  # fmt: skip
        return final.connector

    return run


def throughput(sizes, repeats, budget):
    rows = []
    for n in sizes:
        n_steps = int(max(10, min(5000, budget / n)))
        q0 = 0.5 * np.random.default_rng(0).standard_normal((n, 3))
        bandwidth = copy_bandwidth((n, 3), jnp.float64, n_steps)
        row = {"n_dumbbells": n, "n_steps": n_steps, "bound_steps_per_s": bandwidth / 48}
        for noise in ("gaussian", "three_point"):
            run = jax_runner(n, n_steps, noise)
            key, q0j = jax.random.key(1), jnp.asarray(q0)
            t0 = time.perf_counter()
            jax.block_until_ready(run(key, q0j))
            compile_s = time.perf_counter() - t0
            t_jax = best_of(lambda: jax.block_until_ready(run(key, q0j)), repeats)  # noqa: B023
            rng = np.random.default_rng(2)
            t_np = best_of(lambda: numpy_run(q0, n_steps, noise, rng), repeats)  # noqa: B023
            row[noise] = {
                "jax_steps_per_s": n * n_steps / t_jax,
                "numpy_steps_per_s": n * n_steps / t_np,
                "ratio": t_np / t_jax,
                "jax_first_call_s": compile_s,
                "fraction_of_bound": n * n_steps / t_jax / row["bound_steps_per_s"],
            }
        rows.append(row)
        g, t = row["gaussian"], row["three_point"]
        print(
            f"{n:>9d} {n_steps:>6d} | {g['jax_steps_per_s']:9.3g} {g['numpy_steps_per_s']:9.3g} "
            f"{g['ratio']:6.2f} | {t['jax_steps_per_s']:9.3g} {t['numpy_steps_per_s']:9.3g} "
            f"{t['ratio']:6.2f} | {g['fraction_of_bound']:8.2%} {t['fraction_of_bound']:8.2%}",
            flush=True,
        )
    return rows


def gradient_memory(lengths, n_dumbbells, run_limit_bytes):
    kappa = velocity_gradient("shear", DE)
    rows = []
    for n_steps in lengths:
        row = {"n_steps": n_steps, "n_dumbbells": n_dumbbells}
        for label, mode, ckpt in (
            ("reverse", "reverse", None),
            ("reverse_checkpoint", "reverse", "sqrt"),
            ("forward", "forward", None),
        ):

            def average(b, ckpt=ckpt, n_steps=n_steps):
                out = stationary_average(
                    jax.random.key(0), FENE(b), kappa, DT, n_dumbbells=n_dumbbells, n_burn=0,
                    n_average=n_steps, noise="three_point", checkpoint_every=ckpt,
                )  # fmt: skip
                return out["fqq"][0, 1]

            if mode == "reverse":
                fn = jax.jit(jax.grad(average))
            else:
                fn = jax.jit(lambda b, average=average: jax.jvp(average, (b,), (1.0,))[1])
            b0 = jnp.float64(B)
            compiled = fn.lower(b0).compile()
            temp = compiled.memory_analysis().temp_size_in_bytes
            entry = {"temp_bytes": int(temp), "wall_s": None, "gradient": None}
            if temp <= run_limit_bytes:
                jax.block_until_ready(compiled(b0))
                t0 = time.perf_counter()
                entry["gradient"] = float(compiled(b0))
                entry["wall_s"] = time.perf_counter() - t0
            row[label] = entry
        rows.append(row)
        cells = []
        for label in ("reverse", "reverse_checkpoint", "forward"):
            e = row[label]
            wall = f"{e['wall_s']:.2f}s" if e["wall_s"] is not None else "  (not run)"
            cells.append(f"{e['temp_bytes'] / 2**20:9.1f} MiB {wall:>10}")
        print(f"{n_steps:>7d} | " + " | ".join(cells), flush=True)
    return rows


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="small smoke run")
    parser.add_argument("--repeats", type=int, default=2)
    parser.add_argument("--output", type=Path, default=RESULTS)
    args = parser.parse_args()
    jaxdpd.enable_float64()  # the float64 connectors are made here
    if args.quick:
        sizes, budget, lengths, n_grad = [1000, 10000], 2e6, [100, 400], 256
    else:
        sizes, budget, lengths, n_grad = (
            [1000, 10_000, 100_000, 1_000_000],
            6e6,
            [250, 1000, 4000, 16000],
            1000,
        )

    print(f"jaxdpd {jaxdpd.__version__}, jax {jax.__version__}, numpy {np.__version__}, "
          f"{platform.processor() or platform.machine()}, {os.cpu_count()} cpus, "
          f"device {jax.devices()[0]}")  # fmt: skip
    print("\nFENE b=50, shear De=1, dt=0.01, float64: dumbbell-steps per second")
    print(
        f"{'dumbbells':>9} {'steps':>6} | {'gaussian':^26} | {'three-point':^26}\n"
        f"{'':>9} {'':>6} | {'jax':>9} {'numpy':>9} {'ratio':>6} | "
        f"{'jax':>9} {'numpy':>9} {'ratio':>6} | fraction of memory bound"
    )
    rows = throughput(sizes, args.repeats, budget)

    print(f"\nPathwise gradient d<fQxQy>/db, {n_grad} dumbbells: XLA temp memory, wall time")
    print(f"{'steps':>7} | {'reverse (no checkpoint)':^24} | {'reverse, sqrt(n) ckpt':^24} | "
          f"{'forward (jvp)':^24}")  # fmt: skip
    mem = gradient_memory(lengths, n_grad, run_limit_bytes=2 * 2**30)

    args.output.parent.mkdir(parents=True, exist_ok=True)
    payload = {
        "benchmark": "brownian_throughput",
        "spring": {"kind": "FENE", "b": B},
        "flow": {"kind": "shear", "De": DE},
        "dt": DT,
        "dtype": "float64",
        "quick": args.quick,
        "versions": {"jaxdpd": jaxdpd.__version__, "jax": jax.__version__, "numpy": np.__version__},
        "machine": {
            "cpus": os.cpu_count(),
            "processor": platform.processor(),
            "device": str(jax.devices()[0]),
        },  # fmt: skip
        "throughput": rows,
        "gradient_memory": mem,
    }
    args.output.write_text(json.dumps(payload, indent=2))
    print(f"\nwrote {args.output}")


if __name__ == "__main__":
    main()
