"""How far a decomposed trajectory departs from the single-device one, beside how far
the single-device trajectory departs from itself after a 1-ulp change.

Both start from the same state (float64 Groot–Warren fluid, ρ = 3, a = 25, γ = 4.5,
Δt = 0.04, λ = 0.65, 6 × 10 × 6 box, seed 3).  The decomposed run sums each
particle's forces in another order, a round-off difference at every step; the
reference perturbation changes one coordinate by one ulp once.  The table gives the
largest position difference (minimum image not applied: a particle that wrapped on
one side only counts as a box length) every `--every` steps.

Usage:
    python benchmarks/decomposition_divergence.py [--devices 4] [--steps 300] [--every 25]
Writes benchmarks/results/decomposition_divergence.json.
"""

import argparse
import os


def main() -> None:
    parser = argparse.ArgumentParser()
    parser.add_argument("--devices", type=int, default=4)
    parser.add_argument("--steps", type=int, default=300)
    parser.add_argument("--every", type=int, default=25)
    args = parser.parse_args()
    os.environ["XLA_FLAGS"] = f"--xla_force_host_platform_device_count={args.devices}"
    import numpy as np
    from _common import print_table, write_json

    from jaxdpd.engine.build import build
    from jaxdpd.run import driver
    from jaxdpd.scene import Scene

    data = {
        "seed": 3,
        "precision": "float64",
        "box": {"lengths": [6.0, 10.0, 6.0]},
        "particles": {"density": 3.0},
        "solvent": {"method": "dpd", "kT": 1.0, "gamma": 4.5},
        "pair": {"a": 25.0},
        "integrator": {"dt": 0.04, "lambda": 0.65},
    }
    single = build(Scene.from_dict(data))
    split = build(Scene.from_dict({**data, "parallel": {"devices": args.devices}}))
    reference = single.init_fn()
    x = float(reference.positions[0, 0])
    nudged = reference.set(positions=reference.positions.at[0, 0].set(np.nextafter(x, np.inf)))
    decomposed = split.init_fn()
    rows = []
    for done in range(args.every, args.steps + 1, args.every):
        reference = driver.run(single, reference, args.every, args.every)
        nudged = driver.run(single, nudged, args.every, args.every)
        decomposed = driver.run(split, decomposed, args.every, args.every)
        positions = np.asarray(reference.positions)
        rows.append(
            {
                "step": done,
                "decomposed": float(np.max(np.abs(decomposed.positions - positions))),
                "one_ulp": float(np.max(np.abs(np.asarray(nudged.positions) - positions))),
            }
        )
        print(rows[-1], flush=True)
    print_table(["step", "decomposed", "one_ulp"], rows)
    write_json("decomposition_divergence", {"devices": args.devices, "rows": rows})


if __name__ == "__main__":
    main()
