"""Cost of MPCD (SRD) under flow relative to the same fluid at rest, in one process.

System: ρ = 10 particles per cell, a = 1, α = 130°, h = 0.1, MBS thermostat, no
monomers, temperature observed; the same box edges L × L_y × L at rest (periodic), in
steady shear (Lees–Edwards, γ̇ = 0.2) and in planar elongation (Kraynik–Reinelt case
1, ε̇ = 0.2; collision cells in lattice coordinates, docs/solvent_flows/mpcd.md).  The
three compiled chunks run in turn, three rounds, so that load changes on a shared
machine hit all of them; the best round of each is kept.

Usage:
    python benchmarks/mpcd_flow_cost.py [--edge 20] [--length-y 10]
        [--precision float32] [--steps 50]
Writes benchmarks/results/mpcd_flow_cost.json.
"""

import argparse

import jax
from _common import print_table, timed, write_json

from jaxdpd.engine.build import build
from jaxdpd.run import driver
from jaxdpd.scene import Scene

FLOWS = {
    "rest": None,
    "shear": {"kind": "shear", "shear_rate": 0.2},
    "planar_elongation": {"kind": "planar_elongation", "elongation_rate": 0.2},
}


def scene(flow, edge: float, length_y: float, precision: str) -> Scene:
    data = {
        "seed": 1,
        "precision": precision,
        "box": {"lengths": [edge, length_y, edge]},
        "particles": {"density": 10.0},
        "solvent": {
            "method": "mpcd",
            "collision_time": 0.1,
            "thermostat": "maxwell_boltzmann_scaling",
        },
        "output": {"observables": ["temperature"]},
    }
    if flow is not None:
        data["flow"] = flow
    return Scene.from_dict(data)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--edge", type=float, default=20.0)
    parser.add_argument("--length-y", type=float, default=10.0)
    parser.add_argument("--precision", default="float32")
    parser.add_argument("--steps", type=int, default=50)
    args = parser.parse_args()
    runs = {}
    for name, flow in FLOWS.items():
        simulation = build(scene(flow, args.edge, args.length_y, args.precision))
        state = simulation.init_fn()
        compiled = driver._scan_chunk.lower(simulation.step_fn, state, args.steps).compile()
        (state, _), _ = timed(compiled, state)
        runs[name] = [compiled, state, []]
    for _ in range(3):
        for run in runs.values():
            (run[1], _), seconds = timed(run[0], run[1])
            run[2].append(seconds)
    count = runs["rest"][1].positions.shape[0]
    rest = min(runs["rest"][2])
    rows = [
        {
            "flow": name,
            "N": count,
            "seconds_per_collision": min(run[2]) / args.steps,
            "relative_to_rest": min(run[2]) / rest,
            "flags": int(run[1].flags),
        }
        for name, run in runs.items()
    ]
    print_table(["flow", "N", "seconds_per_collision", "relative_to_rest", "flags"], rows)
    system = vars(args) | {"density": 10.0, "collision_time": 0.1, "rates": 0.2}
    devices = [str(d) for d in jax.devices()]
    path = write_json("mpcd_flow_cost", {"system": system, "devices": devices, "rows": rows})
    print(f"wrote {path}")


if __name__ == "__main__":
    main()
