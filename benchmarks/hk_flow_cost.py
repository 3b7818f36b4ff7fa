"""Cost of the Hoogerbrugge–Koelman step in flow, relative to the same fluid at rest.

System: the default HK fluid (Π0 = 1/3, ω = 4/3, Δ = 1/3, ρ = 3, δt = 1) in a cubic
box of edge L (N = 3 L³), temperature and pressure observed, cell-list neighbours;
flows: none (periodic box), steady shear γ̇ = 0.01 (Lees–Edwards), oscillatory shear
(γ̇0 = 0.01, ω = 0.05) and planar elongation ε̇ = 0.005 (Kraynik–Reinelt, case 1).
Each scene is compiled on a first chunk; then the four are timed in turn, round
after round, in one process, so that a shared machine slows them alike; the median
seconds per step over the rounds is reported with its ratio to the box at rest.

Usage:
    python benchmarks/hk_flow_cost.py [--edge 10] [--precision float32]
        [--steps 100] [--rounds 5]
Writes benchmarks/results/hk_flow_cost.json.
"""

import argparse

import numpy as np
from _common import print_table, timed, write_json

from jaxdpd.engine.build import build
from jaxdpd.run import driver
from jaxdpd.scene import Scene

FLOWS = {
    "rest": None,
    "shear": {"kind": "shear", "shear_rate": 0.01},
    "oscillatory_shear": {"kind": "shear", "shear_rate": 0.01, "oscillation_frequency": 0.05},
    "planar_elongation": {"kind": "planar_elongation", "elongation_rate": 0.005},
}


def hk_scene(edge: float, precision: str, flow) -> Scene:
    data = {
        "seed": 1,
        "precision": precision,
        "box": {"lengths": [edge] * 3},
        "particles": {"density": 3.0},
        "solvent": {"method": "hoogerbrugge_koelman"},
        "output": {"observables": ["temperature", "pressure"]},
    }
    if flow is not None:
        data["flow"] = flow
    return Scene.from_dict(data)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--edge", type=float, default=10.0)
    parser.add_argument("--precision", default="float32")
    parser.add_argument("--steps", type=int, default=100)
    parser.add_argument("--rounds", type=int, default=5)
    args = parser.parse_args()
    runs = {}
    for name, flow in FLOWS.items():
        simulation = build(hk_scene(args.edge, args.precision, flow))
        state = driver.run(simulation, simulation.init_fn(), args.steps, args.steps)
        runs[name] = [simulation, state, []]
    for _ in range(args.rounds):
        for run in runs.values():
            simulation, state, times = run
            (state, _, _), seconds = timed(driver.run_chunk, simulation, state, args.steps)
            run[1] = state
            times.append(seconds / args.steps)
    rest = float(np.median(runs["rest"][2]))
    rows = []
    for name, (simulation, _, times) in runs.items():
        per_step = float(np.median(times))
        rows.append(
            {
                "flow": name,
                "particles": simulation.scene.n_particles,
                "ms_per_step": 1e3 * per_step,
                "spread_ms": 1e3 * float(np.ptp(times)),
                "relative_to_rest": per_step / rest,
            }
        )
    print_table(["flow", "particles", "ms_per_step", "spread_ms", "relative_to_rest"], rows)
    path = write_json("hk_flow_cost", {"arguments": vars(args), "rows": rows})
    print(f"wrote {path}")


if __name__ == "__main__":
    main()
