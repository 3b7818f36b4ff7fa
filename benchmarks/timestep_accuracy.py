"""What the time step costs in accuracy: ⟨k_BT⟩ and pressure against Δt and λ.

Groot–Warren DPD fluid, ρ = 3, a = 25, γ = 4.5 (σ = 3), k_BT = 1, N = 3000, float64,
modified velocity Verlet (thesis eq. 2.10) at Δt ∈ {0.01, 0.02, 0.04, 0.06} and
λ ∈ {0.5, 0.65}.  Each run equilibrates for 10 time units and samples 40 time units;
errors are standard errors from 20 block averages.  The cost is wall time per unit of
simulated time (compilation excluded).

Usage:
    python benchmarks/timestep_accuracy.py [--n 3000] [--time 40] [--quick]
Writes benchmarks/results/timestep_accuracy.json.
"""

import argparse
import math
import time

import numpy as np
from _common import print_table, write_json

from jaxdpd.analysis.statistics import block_average
from jaxdpd.engine.build import build
from jaxdpd.run import driver
from jaxdpd.scene import Scene


def sample(data: dict, steps: int, chunk: int, equilibration_steps: int):
    """Run a scene and time its sampling.

    Args:
        data: the scene as a dictionary (`Scene.from_dict`).
        steps: sampled steps, a whole number of chunks.
        chunk: steps per jitted scan (one compilation serves equilibration, warm-up
            and sampling when `equilibration_steps` is a multiple of it).
        equilibration_steps: steps run before sampling, not timed.
    Returns:
        (series: name → per-step NumPy array over the sampled steps, wall seconds of
        the sampled steps, compilation excluded).
    """
    simulation = build(Scene.from_dict(data))
    state = driver.run(simulation, simulation.init_fn(), equilibration_steps, chunk)
    parts = {}

    def collect(result):
        for name, values in result.series.items():
            parts.setdefault(name, []).append(values)

    driver.run(simulation, state, chunk, chunk)  # compile outside the timing
    start = time.perf_counter()
    driver.run(simulation, state, steps, chunk, on_chunk=collect)
    seconds = time.perf_counter() - start
    return {name: np.concatenate(values) for name, values in parts.items()}, seconds


def measure(
    n: int,
    dt: float,
    lam: float,
    sample_time: float,
    equilibration_time: float,
    precision: str = "float64",
    skin: float = 0.0,
):
    """⟨k_BT⟩ and pressure (20 block averages) and wall seconds per time unit of the
    Groot–Warren fluid at one (Δt, λ, precision, neighbour skin)."""
    scene = {
        "seed": 11,
        "precision": precision,
        "particles": {"density": 3.0, "count": n},
        "solvent": {"method": "dpd", "kT": 1.0, "gamma": 4.5},
        "pair": {"a": 25.0},
        "integrator": {"dt": dt, "lambda": lam},
        "neighbors": {"skin": skin},
        "output": {"observables": ["temperature", "pressure"]},
    }
    chunk = max(1, round(sample_time / dt) // 20)
    equilibration = chunk * math.ceil(equilibration_time / dt / chunk)
    series, seconds = sample(scene, chunk * 20, chunk, equilibration)
    row = {"dt": dt, "lambda": lam, "steps": chunk * 20}
    for name in ("temperature", "pressure"):
        mean, error = block_average(series[name], n_blocks=20)
        row[name] = float(mean)
        row[f"{name}_err"] = float(error)
    row["kT_deviation_%"] = 100 * (row["temperature"] - 1.0)
    row["wall_s_per_time_unit"] = seconds / (chunk * 20 * dt)
    return row


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--n", type=int, default=3000)
    parser.add_argument("--time", type=float, default=40.0, help="sampled time units")
    parser.add_argument("--quick", action="store_true", help="N = 1000, 8 time units")
    args = parser.parse_args()
    n, sample_time = (1000, 8.0) if args.quick else (args.n, args.time)
    rows = []
    for lam in (0.5, 0.65):
        for dt in (0.01, 0.02, 0.04, 0.06):
            rows.append(measure(n, dt, lam, sample_time, 10.0))
            print_table(list(rows[-1]), rows[-1:])
    columns = [
        "dt",
        "lambda",
        "temperature",
        "temperature_err",
        "kT_deviation_%",
        "pressure",
        "pressure_err",
        "wall_s_per_time_unit",
    ]
    print()
    print_table(columns, rows)
    path = write_json("timestep_accuracy", {"N": n, "sample_time": sample_time, "rows": rows})
    print(f"wrote {path}")


if __name__ == "__main__":
    main()
