"""Equilibrium size of DPD FENE dumbbells against the ideal FENE result (thesis fig. 4-4).

FENE dumbbells with b = H Q0²/k_BT = 50 at 25 % of the particles of a Groot–Warren
θ-solvent (ρ = 3, a = 25 between all particles, γ = 4.5, k_BT = 1, Δt = 0.04,
λ = 0.65; thesis §4.2.9), for Q0 ∈ {3, 5, 10, 20}.  Without pair forces a dumbbell
has ⟨Q²⟩/Q0² = 3/(b + 5) exactly (thesis eq. 4.8, tested in
tests/test_polymer_statistics.py); in DPD the beads of a dumbbell also repel each
other within r_c = 1, which stretches short dumbbells: the thesis reports that the
smaller Q0, the larger the excess (fig. 4-4).

Each box is cubic with edge L = max(2 Q0 + 1, 8) (a spring must stay shorter than
L/2, thesis §3.2.3), so Q0 = 20 needs N ≈ 2.1e5 particles.  Errors are standard errors
of 20 block averages of the per-step mean over all dumbbells.

Usage:
    python benchmarks/dumbbell_size.py [--q0 3 5 10 20] [--equilibration 500] [--steps 1000]
        [--dt 0.04]
Writes benchmarks/results/dumbbell_size.json (dumbbell_size_dt<Δt>.json for another Δt).
"""

import argparse
import time

import numpy as np
from _common import print_table, write_json

from jaxdpd.analysis.statistics import block_average
from jaxdpd.engine.build import build
from jaxdpd.run import driver
from jaxdpd.scene import Scene

B = 50.0
DENSITY = 3.0
POLYMER_FRACTION = 0.25
DEFAULT_TIME_STEP = 0.04


def dumbbell_scene(max_extension: float, time_step: float = DEFAULT_TIME_STEP) -> Scene:
    side = max(2 * max_extension + 1, 8.0)
    return Scene.from_dict(
        {
            "seed": 5,
            "precision": "float32",
            "box": {"lengths": [side] * 3},
            "particles": {
                "density": DENSITY,
                "species": [
                    {"name": "dumbbell", "fraction": POLYMER_FRACTION},
                    {"name": "solvent", "fraction": 1 - POLYMER_FRACTION},
                ],
            },
            "solvent": {"method": "dpd", "kT": 1.0, "gamma": 4.5},
            "pair": {"a": 25.0},
            "polymers": [
                {
                    "species": "dumbbell",
                    "beads": 2,
                    "bond": {
                        "law": "fene",
                        "spring_constant": B / max_extension**2,
                        "max_extension": max_extension,
                    },
                }
            ],
            "integrator": {"dt": time_step, "lambda": 0.65},
            "output": {"observables": ["temperature", "conformation"]},
        }
    )


def measure(max_extension: float, equilibration: int, steps: int, time_step: float) -> dict:
    scene = dumbbell_scene(max_extension, time_step)
    simulation = build(scene)
    chunk = max(1, steps // 20)
    state = driver.run(simulation, simulation.init_fn(), equilibration, chunk)
    state = simulation.reallocate(state, None)
    series = {"dumbbell/bond_length_sq": [], "temperature": []}

    def collect(result):
        for name in series:
            series[name].append(np.asarray(result.series[name], np.float64))

    start = time.perf_counter()
    driver.run(simulation, state, chunk * 20, chunk, on_chunk=collect)
    seconds = time.perf_counter() - start
    q_sq, q_sq_err = block_average(np.concatenate(series["dumbbell/bond_length_sq"]), 20)
    temperature, temperature_err = block_average(np.concatenate(series["temperature"]), 20)
    ideal = 3 / (B + 5)
    relative = float(q_sq) / max_extension**2
    return {
        "Q0": max_extension,
        "N": scene.n_particles,
        "dumbbells": scene.particles.species[0].count // 2,
        "Q2_over_Q0sq": relative,
        "Q2_over_Q0sq_err": float(q_sq_err) / max_extension**2,
        "ideal_3_over_b_plus_5": ideal,
        "excess_%": 100 * (relative / ideal - 1),
        "kT": float(temperature),
        "kT_err": float(temperature_err),
        "wall_s": seconds,
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--q0", type=float, nargs="+", default=[3.0, 5.0, 10.0, 20.0])
    parser.add_argument("--equilibration", type=int, default=500)
    parser.add_argument("--steps", type=int, default=1000)
    parser.add_argument("--dt", type=float, default=DEFAULT_TIME_STEP, help="time step Δt")
    args = parser.parse_args()
    rows = []
    for max_extension in args.q0:
        rows.append(measure(max_extension, args.equilibration, args.steps, args.dt))
        print_table(list(rows[-1]), rows[-1:])
    print()
    print_table(list(rows[0]), rows)
    name = "dumbbell_size" if args.dt == DEFAULT_TIME_STEP else f"dumbbell_size_dt{args.dt:g}"
    path = write_json(
        name,
        {
            "b": B,
            "dt": args.dt,
            "equilibration": args.equilibration,
            "steps": args.steps,
            "rows": rows,
        },
    )
    print(f"wrote {path}")


if __name__ == "__main__":
    main()
