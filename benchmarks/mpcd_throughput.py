"""Throughput of an MPCD (SRD) solvent: particle-collisions per second against N.

System: ρ = 10 particles per cell, a = 1, α = 130°, h = 0.1, k_BT = 1, no monomers;
one step = ballistic streaming over h + one SRD collision with a random grid shift
(the scene's step, built by jaxdpd.engine.build.build, with the temperature observed).
The rate is measured over whole jitted chunks after a compiling one, each timed chunk
after an untimed one.

The bound: a step must at least read and write every particle's position and
velocity, 12 values; the copy bandwidth B of that much data is measured in the same
run (benchmarks/_common.copy_bandwidth), so bound = B / (12 · bytes per value)
particle-collisions/s and the fraction of it reached is printed beside the rate.

A plain NumPy implementation of the same step (streaming, shift, binning, per-cell
sums by np.bincount, random axes, Rodrigues rotation) runs in the same process on
the same configuration, alternating with jaxdpd, so that the ratio is meaningful on
a shared machine.

Usage:
    python benchmarks/mpcd_throughput.py [--sizes 100000 1000000]
        [--precisions float32 float64] [--steps 20]
Writes benchmarks/results/mpcd_throughput.json.
"""

import argparse
import math
import time

import jax
import numpy as np
from _common import copy_bandwidth, peak_rss_mib, print_table, timed, write_json

from jaxdpd.engine.build import build
from jaxdpd.run import driver
from jaxdpd.scene import Scene

DENSITY, ANGLE, COLLISION_TIME = 10.0, 130.0, 0.1
VALUES_PER_UPDATE = 12  # positions and velocities, read and written


def solvent_scene(n: int, precision: str) -> Scene:
    """A cubic box of whole cells holding about n particles at ρ = 10."""
    edge = round((n / DENSITY) ** (1 / 3))
    return Scene.from_dict(
        {
            "seed": 1,
            "precision": precision,
            "box": {"lengths": [edge] * 3},
            "particles": {"density": DENSITY},
            "solvent": {
                "method": "mpcd",
                "rotation_angle": ANGLE,
                "collision_time": COLLISION_TIME,
            },
            "output": {"observables": ["temperature"]},
        }
    )


def numpy_step(positions, velocities, rng, edge: int, dtype):
    """The same MPCD step in plain NumPy (unit masses, cell size 1)."""
    positions = np.mod(positions + COLLISION_TIME * velocities, edge)
    shift = rng.uniform(size=3).astype(dtype)
    index = np.floor(np.mod(positions - shift, edge)).astype(np.int64) % edge
    cell = index[:, 0] + edge * (index[:, 1] + edge * index[:, 2])
    n_cells = edge**3
    count = np.bincount(cell, minlength=n_cells)
    mean = (
        np.stack([np.bincount(cell, velocities[:, k], minlength=n_cells) for k in range(3)], axis=1)
        / np.maximum(count, 1)[:, None]
    )
    cos_theta = rng.uniform(-1, 1, n_cells)
    phi = rng.uniform(0, 2 * np.pi, n_cells)
    sin_theta = np.sqrt(1 - cos_theta**2)
    axes = np.stack([sin_theta * np.cos(phi), sin_theta * np.sin(phi), cos_theta], axis=1)
    relative = velocities - mean[cell]
    n = axes[cell]
    c, s = math.cos(math.radians(ANGLE)), math.sin(math.radians(ANGLE))
    along = np.sum(n * relative, axis=1, keepdims=True)
    rotated = relative * c + np.cross(n, relative) * s + n * along * (1 - c)
    return positions, (mean[cell] + rotated).astype(dtype)


def measure(n: int, precision: str, steps: int) -> list[dict]:
    scene = solvent_scene(n, precision)
    simulation = build(scene)
    state = simulation.init_fn()
    start = time.perf_counter()
    compiled = driver._scan_chunk.lower(simulation.step_fn, state, steps).compile()
    compile_seconds = time.perf_counter() - start
    (state, _), _ = timed(compiled, state)
    dtype = np.dtype(precision)
    positions = np.asarray(state.positions)
    velocities = np.asarray(state.velocities)
    rng = np.random.default_rng(0)
    jax_seconds, numpy_seconds = [], []
    for _ in range(3):  # alternate, so that load changes on a shared machine hit both
        # A chunk right after another program's runs slower: time the one after it.
        state, _ = jax.block_until_ready(compiled(state))
        (state, samples), seconds = timed(compiled, state)
        jax_seconds.append(seconds)
        start = time.perf_counter()
        for _ in range(steps):
            positions, velocities = numpy_step(
                positions, velocities, rng, round(scene.box.lengths[0]), dtype
            )
        numpy_seconds.append(time.perf_counter() - start)
    if int(state.flags):
        raise RuntimeError(f"jaxdpd run flagged errors {int(state.flags)}")
    count = scene.n_particles
    temperature = float(np.trace(np.asarray(samples["kinetic"])[-1]) / (3 * (count - 1)))
    jax_rate = count * steps / min(jax_seconds)
    numpy_rate = count * steps / min(numpy_seconds)
    bandwidth = copy_bandwidth((count, 6), dtype, steps)
    bound = bandwidth / (VALUES_PER_UPDATE * dtype.itemsize)
    return [
        {
            "code": "jaxdpd",
            "N": count,
            "precision": precision,
            "particle_collisions_per_s": jax_rate,
            "ratio_to_numpy": jax_rate / numpy_rate,
            "copy_GB_per_s": bandwidth / 1e9,
            "bound_per_s": bound,
            "fraction_of_bound": jax_rate / bound,
            "compile_s": compile_seconds,
            "temperature": temperature,
            "peak_rss_mib": peak_rss_mib(),
        },
        {
            "code": "numpy",
            "N": count,
            "precision": precision,
            "particle_collisions_per_s": numpy_rate,
            "ratio_to_numpy": 1.0,
            "temperature": float(np.mean(velocities.astype(np.float64) ** 2)),
        },
    ]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sizes", type=int, nargs="+", default=[100_000, 1_000_000])
    parser.add_argument("--precisions", nargs="+", default=["float32", "float64"])
    parser.add_argument("--steps", type=int, default=20)
    args = parser.parse_args()
    rows = [
        row
        for n in args.sizes
        for precision in args.precisions
        for row in measure(n, precision, args.steps)
    ]
    columns = ["code", "N", "precision", "particle_collisions_per_s", "ratio_to_numpy"]
    print_table(columns + ["fraction_of_bound", "compile_s", "temperature"], rows)
    path = write_json(
        "mpcd_throughput",
        {
            "system": {
                "density": DENSITY,
                "rotation_angle_deg": ANGLE,
                "collision_time": COLLISION_TIME,
                "steps_per_chunk": args.steps,
            },
            "devices": [str(d) for d in jax.devices()],
            "rows": rows,
        },
    )
    print(f"wrote {path}")


if __name__ == "__main__":
    main()
