"""Why the first-run notebook measured k_BT = 1.0039 ± 0.0010: a time-step artefact, an
error bar too small, or a bug?

The notebook's fluid (notebooks/first_run.ipynb: Groot–Warren DPD, ρ = 3, a = 25,
γ = 4.5, k_BT = 1, N = 3000, float32, λ = 0.65, seed 1, 250 equilibration steps) is
run for a long production at Δt = 0.04 (whose first 3000 steps are the notebook's run)
and at Δt = 0.02 (the time-step artefact of the modified velocity Verlet shrinks with
Δt; Groot & Warren, J. Chem. Phys. 107, 4423 (1997)).  Each ⟨k_BT⟩ is given with the
table's error (20 block averages) and the blocking-plateau error
(jaxdpd.analysis.statistics.blocking_plateau), the latter a lower bound when no
plateau is reached.

Usage:
    python benchmarks/first_run_temperature.py [--time 400] [--quick]
Writes benchmarks/results/first_run_temperature.json (about 10 min on 2 shared cores).
"""

import argparse

import numpy as np
from _common import print_table, write_json

from jaxdpd.analysis.statistics import block_average, blocking_plateau
from jaxdpd.run.runner import simulate
from jaxdpd.scene import Scene

NOTEBOOK_STEPS = 3000


def notebook_scene(dt: float, steps: int) -> Scene:
    """The first-run notebook's scene at time step `dt`, `steps` production steps, no
    file (the observables of the notebook, so the float32 arithmetic is the same)."""
    return Scene.from_dict(
        {
            "seed": 1,
            "precision": "float32",
            "particles": {"density": 3.0, "count": 3000},
            "solvent": {"method": "dpd", "kT": 1.0, "gamma": 4.5},
            "pair": {"a": 25.0},
            "integrator": {"dt": dt, "lambda": 0.65},
            "run": {"equilibration": 250, "steps": steps, "chunk": 250},
            "output": {"observables": ["temperature", "pressure", "rdf"]},
        }
    )


def row(label: str, dt: float, temperature: np.ndarray) -> dict:
    mean, table_error = (float(x) for x in block_average(temperature, 20))
    plateau, plateau_error = blocking_plateau(temperature)
    error = max(table_error, plateau_error)
    return {
        "run": label,
        "dt": dt,
        "steps": len(temperature),
        "kT": mean,
        "table_err": table_error,
        "plateau_block": plateau,
        "plateau_err": plateau_error,
        "deviation_%": 100 * (mean - 1),
        "deviation_sigmas": (mean - 1) / error,
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--time", type=float, default=400.0, help="production time units")
    parser.add_argument("--quick", action="store_true", help="40 time units")
    args = parser.parse_args()
    duration = 40.0 if args.quick else args.time
    rows = []
    for dt in (0.04, 0.02):
        steps = 250 * round(duration / dt / 250)
        summary = simulate(notebook_scene(dt, steps), None, progress=False, keep_series=True)
        temperature = np.asarray(summary.series["temperature"], np.float64)
        if dt == 0.04:
            rows.append(row("notebook (first 3000 steps)", dt, temperature[:NOTEBOOK_STEPS]))
        rows.append(row(f"{duration:g} τ", dt, temperature))
        print_table(list(rows[-1]), rows[-1:])
    print()
    print_table(list(rows[0]), rows)
    name = "first_run_temperature" + ("_quick" if args.quick else "")
    path = write_json(name, {"time": duration, "rows": rows})
    print(f"wrote {path}")


if __name__ == "__main__":
    main()
