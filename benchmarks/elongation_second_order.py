"""Elongational viscosities of the DPD fluid beside its shear material functions.

The measurement behind `tests/test_planar_elongation_slow.py`, with more replicas and
split by stress part.  The standard DPD fluid (ρ = 3, a = 25, γ = 4.5, k_BT = 1,
Δt = 0.04, λ = 0.65, float32, N = 768) runs in planar elongation at ε̇ (box 8 × 4 × 8)
and in Lees–Edwards shear at γ̇ (cube), `--replicas` seeds each, after 250 steps at
rest.  Reported per stress part (kinetic, conservative, dissipative, random) and in
total:
- η̄1/4 = (P_xx − P_zz)/4ε̇ and η̄2/2 = (P_xx − P_yy)/2ε̇ (thesis eqs. 3.25–3.26 with
  eq. 5.12: z stretches, x compresses, y neutral);
- η = −P_xy/γ̇ and Ψ1/2 + Ψ2 = (P_zz − (P_xx + P_yy)/2)/γ̇²;
- the second-order-fluid prediction η̄2/2 = η − 2ε̇(Ψ1/2 + Ψ2) (derived in the test);
- the spread of the replica means over their block-average error (1 when the block
  errors are right).

Errors: 20 block averages per replica, combined over replicas by inverse variance.

Usage: python benchmarks/elongation_second_order.py [--replicas 16] [--steps 10000]
    [--elongation-rate 0.2] [--shear-rate 0.2] [--first-seed 21]
Writes benchmarks/results/elongation_second_order.json.
"""

import argparse

import jax.numpy as jnp
import numpy as np
from _common import write_json

from jaxdpd.analysis.statistics import block_average, inverse_variance_mean
from jaxdpd.engine.build import build
from jaxdpd.geometry import flows
from jaxdpd.run import driver, ensemble
from jaxdpd.scene import Scene

TOTAL = "pressure_tensor"
PART = "pressure_tensor_part/"


def fluid(**sections) -> Scene:
    data = {
        "seed": 7,
        "precision": "float32",
        "particles": {"density": 3.0, "count": 768},
        "solvent": {"method": "dpd", "kT": 1.0, "gamma": 4.5},
        "pair": {"a": 25.0},
        "integrator": {"dt": 0.04, "lambda": 0.65},
        "output": {"observables": ["temperature", "pressure"]},
        **sections,
    }
    return Scene.from_dict(data)


def stress_series(scene: Scene, seeds, rates, steps: int) -> dict:
    """{name: (B, T, 3, 3)} stress series of replicas run at the given flow rates."""
    simulation = build(scene)
    kind = scene.flow.kind
    batch = ensemble.replicate(simulation, simulation.init_fn(), seeds=seeds)
    batch = driver.run(simulation, batch, 250, 250)
    batch = flows.set_flow_rate(batch, kind, jnp.asarray(rates))
    parts = {}

    def keep(result):
        for name, values in result.series.items():
            if name.startswith(TOTAL):
                parts.setdefault(name, []).append(np.asarray(values, np.float64))

    driver.run(simulation, batch, steps, 500, on_chunk=keep)
    return {name: np.concatenate(chunks, axis=1) for name, chunks in parts.items()}


def combined(values) -> dict:
    """Inverse-variance mean over replicas of (B, T) values, and the spread check."""
    means, errors = (np.asarray(x) for x in block_average(values, n_blocks=20, axis=1))
    mean, error = inverse_variance_mean(means, errors)
    spread = means.std(ddof=1) / np.sqrt(np.mean(errors**2))
    return {"mean": float(mean), "error": float(error), "spread_over_block_error": float(spread)}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--replicas", type=int, default=16)
    parser.add_argument("--steps", type=int, default=10000)
    parser.add_argument("--elongation-rate", type=float, default=0.2)
    parser.add_argument("--shear-rate", type=float, default=0.2)
    parser.add_argument("--first-seed", type=int, default=21)
    args = parser.parse_args()
    seeds = list(range(args.first_seed, args.first_seed + args.replicas))
    rate, shear_rate = args.elongation_rate, args.shear_rate

    elongation = stress_series(
        fluid(
            box={"lengths": [8.0, 4.0, 8.0]},
            particles={"density": 3.0},
            flow={"kind": "planar_elongation", "elongation_rate": 0.0},
        ),
        seeds,
        [rate] * args.replicas,
        args.steps,
    )
    shear = stress_series(
        fluid(flow={"kind": "shear", "shear_rate": 0.0}),
        seeds,
        [shear_rate] * args.replicas,
        args.steps,
    )
    rows = []
    for name in sorted(elongation, key=lambda n: (n != TOTAL, n)):
        p, s = elongation[name], shear[name]
        row = {
            "part": name.removeprefix(PART) if name != TOTAL else "total",
            "eta1/4": combined((p[..., 0, 0] - p[..., 2, 2]) / (4 * rate)),
            "eta2/2": combined((p[..., 0, 0] - p[..., 1, 1]) / (2 * rate)),
            "eta2/2 - eta1/4": combined(
                (p[..., 0, 0] + p[..., 2, 2] - 2 * p[..., 1, 1]) / (4 * rate)
            ),
            "eta": combined(-s[..., 0, 1] / shear_rate),
            "psi1/2+psi2": combined(
                (s[..., 2, 2] - (s[..., 0, 0] + s[..., 1, 1]) / 2) / shear_rate**2
            ),
        }
        eta, psi = row["eta"], row["psi1/2+psi2"]
        row["predicted eta2/2"] = {
            "mean": eta["mean"] - 2 * rate * psi["mean"],
            "error": float(np.hypot(eta["error"], 2 * rate * psi["error"])),
        }
        rows.append(row)
        cells = [f"{k} {v['mean']:+.4f} ± {v['error']:.4f}" for k, v in row.items() if k != "part"]
        print(f"{row['part']:>12}: " + "; ".join(cells))
    print("replica spread / block error:")
    for row in rows:
        ratios = [
            f"{k} {v['spread_over_block_error']:.2f}"
            for k, v in row.items()
            if k != "part" and "spread_over_block_error" in v
        ]
        print(f"{row['part']:>12}: " + ", ".join(ratios))
    payload = {
        "replicas": args.replicas,
        "steps": args.steps,
        "elongation_rate": rate,
        "shear_rate": shear_rate,
        "seeds": seeds,
        "rows": rows,
    }
    print("wrote", write_json("elongation_second_order", payload))


if __name__ == "__main__":
    main()
