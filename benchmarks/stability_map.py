"""Stability map: the measured ⟨k_BT⟩ of each particle solvent against shear rate and Δt.

A DPD fluid under strong shear heats: the integrator's error grows with the relative
velocities, which the flow raises (the flow-curve notebook measures k_BT = 1.48 at
γ̇ = 2 with Groot–Warren at Δt = 0.04).  The thesis keeps its fluid at temperature
with the Lowe–Andersen thermostat at Δt = 0.01 (error below 0.5 % at every rate,
thesis §4.3.1) and stays below γ̇ ≈ 0.3, above which the simple DPD fluid stops
behaving like a fluid (thesis §4.2.7).  This script measures, for each solvent, the
temperature at each (γ̇, Δt) of a grid and whether jaxdpd.analysis.temperature_check flags it
(more than 3 % and 3 standard errors off), or the run stops (error flags).

Fluids (ρ = 3, a = 25, k_BT = 1, N = 375 in a 5³ Lees–Edwards box, float64):
    dpd:            Groot–Warren, γ = 4.5 (σ = 3), λ = 0.65
    lowe_andersen:  Γ = 10 (Γ Δt ≤ 1 on the whole grid), r_T = r_c
Each point equilibrates for 5 time units under shear and samples 10 (20 blocks);
this default grid is small (the machine it ran on had 2 busy cores): read it as the
location of the limits, not their precise values.

Usage:
    python benchmarks/stability_map.py [--time 10] [--n 375]
Writes benchmarks/results/stability_map.json and prints one table per solvent.
"""

import argparse
import math
import time

import jax.numpy as jnp
import numpy as np
from _common import print_table, write_json

from jaxdpd.analysis.statistics import block_average
from jaxdpd.analysis.temperature_check import is_off
from jaxdpd.engine.build import build
from jaxdpd.engine.errors import SimulationError
from jaxdpd.run import driver
from jaxdpd.scene import Scene

SHEAR_RATES = (0.0, 0.3, 1.0, 2.0)
TIME_STEPS = (0.01, 0.02, 0.04, 0.06, 0.1)
SOLVENTS = {
    "dpd": ({"method": "dpd", "kT": 1.0, "gamma": 4.5}, 0.65),
    "lowe_andersen": ({"method": "lowe_andersen", "kT": 1.0, "collision_frequency": 10.0}, 0.5),
}


def scene(solvent: str, dt: float, n: int) -> Scene:
    """The sheared fluid of `solvent` at step Δt (rate set per run)."""
    section, lam = SOLVENTS[solvent]
    integrator = {"dt": dt, "lambda": lam} if solvent == "dpd" else {"dt": dt}
    return Scene.from_dict(
        {
            "seed": 5,
            "precision": "float64",
            "particles": {"density": 3.0, "count": n},
            "solvent": section,
            "pair": {"a": 25.0},
            "integrator": integrator,
            "flow": {"kind": "shear", "shear_rate": 0.0},
            "output": {"observables": ["temperature"]},
        }
    )


def measure(simulation, shear_rate: float, sample_time: float, equilibration_time: float):
    """⟨k_BT⟩, its standard error (20 blocks) and the wall seconds of one state point;
    (NaN, NaN, seconds, message) when the run stops on an error flag."""
    dt = simulation.scene.integrator.dt
    chunk = max(1, round(sample_time / dt) // 20)
    equilibration = chunk * math.ceil(equilibration_time / dt / chunk)
    state = simulation.init_fn()
    rate = jnp.asarray(shear_rate, state.box_state.shear_rate.dtype)
    state = state.set(box_state=state.box_state.set(shear_rate=rate))
    parts = []
    start = time.perf_counter()
    try:
        state = driver.run(simulation, state, equilibration, chunk)
        driver.run(
            simulation,
            state,
            20 * chunk,
            chunk,
            on_chunk=lambda result: parts.append(np.asarray(result.series["temperature"])),
        )
    except SimulationError as error:
        return math.nan, math.nan, time.perf_counter() - start, str(error)
    mean, error = block_average(np.concatenate(parts), n_blocks=20)
    return float(mean), float(error), time.perf_counter() - start, ""


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--n", type=int, default=375)
    parser.add_argument("--time", type=float, default=10.0, help="sampled time units")
    args = parser.parse_args()
    rows = []
    for solvent in SOLVENTS:
        for dt in TIME_STEPS:
            simulation = build(scene(solvent, dt, args.n))
            for rate in SHEAR_RATES:
                mean, error, seconds, stopped = measure(simulation, rate, args.time, 5.0)
                row = {
                    "solvent": solvent,
                    "dt": dt,
                    "shear_rate": rate,
                    "temperature": mean,
                    "temperature_err": error,
                    "kT_deviation_%": 100 * (mean - 1.0),
                    "flagged": bool(is_off(mean, error, 1.0)),
                    "stopped": stopped,
                    "wall_s": seconds,
                }
                rows.append(row)
                print_table(list(row), [row])
    print()
    for solvent in SOLVENTS:
        print(
            f"{solvent}: k_BT (* = flagged by jaxdpd.analysis.temperature_check, X = run stopped)"
        )
        header = ["dt \\ shear_rate", *(f"{rate:g}" for rate in SHEAR_RATES)]
        table = []
        for dt in TIME_STEPS:
            cells = {"dt \\ shear_rate": dt}
            for row in rows:
                if row["solvent"] == solvent and row["dt"] == dt:
                    mark = "X" if row["stopped"] else ("*" if row["flagged"] else "")
                    cells[f"{row['shear_rate']:g}"] = f"{row['temperature']:.3f}{mark}"
            table.append(cells)
        print_table(header, table)
        print()
    payload = {"N": args.n, "sample_time": args.time, "equilibration_time": 5.0, "rows": rows}
    print(f"wrote {write_json('stability_map', payload)}")


if __name__ == "__main__":
    main()
