"""Cost of the Lowe–Andersen step against the Groot–Warren step, and its rounds.

System: ρ = 3, a = 25, k_BT = 1, Δt = 0.01, cell-list neighbours (skin 0, rebuilt
every step), N particles.  Groot–Warren: γ = 4.5 (σ = 3), λ = 0.5.  Lowe–Andersen:
Γ = p/Δt for each selection probability p = ΓΔt, r_T = r_c.  Each scene is
equilibrated, then timed over whole jitted chunks (compilation excluded); the
Groot–Warren and Lowe–Andersen chunks are timed in turn, `--repeats` times, and the
fastest of each is kept, so the ratios compare like with like on a shared machine.

Reported per p: the parallel rounds per step of the exact sequential sweep (mean and
largest; jaxdpd.solvents.lowe_andersen), the pairs thermalised per step and per
particle, the kinetic temperature, and the cost of a step relative to a Groot–Warren
step of the same system.

Usage:
    python benchmarks/lowe_andersen_cost.py [--sizes 3000 12000]
        [--probabilities 0.1 0.5 1.0] [--steps 100] [--repeats 3]
        [--precision float32]
Writes benchmarks/results/lowe_andersen_cost.json.
"""

import argparse
from functools import partial

import jax
import numpy as np
from _common import peak_rss_mib, print_table, timed, write_json

from jaxdpd.engine.build import build
from jaxdpd.observables.thermo import temperature
from jaxdpd.run import driver
from jaxdpd.scene import Scene

DENSITY, REPULSION, GAMMA, DT = 3.0, 25.0, 4.5, 0.01


def scene(n: int, precision: str, probability: float | None) -> Scene:
    """Groot–Warren (probability None) or Lowe–Andersen with Γ = probability/Δt."""
    if probability is None:
        solvent = {"method": "dpd", "kT": 1.0, "gamma": GAMMA}
        integrator = {"dt": DT, "lambda": 0.5}
    else:
        solvent = {"method": "lowe_andersen", "kT": 1.0, "collision_frequency": probability / DT}
        integrator = {"dt": DT}
    return Scene.from_dict(
        {
            "seed": 1,
            "precision": precision,
            "particles": {"density": DENSITY, "count": n},
            "solvent": solvent,
            "pair": {"a": REPULSION},
            "integrator": integrator,
            "output": {"observables": ["temperature"]},
        }
    )


@partial(jax.jit, static_argnums=(0, 2))
def _chunk_with_rounds(step_fn, state, length: int):
    """A scan of `length` steps that also returns each step's thermalisation record."""

    def body(carry, _):
        new, samples = step_fn(carry)
        record = new.solvent_state
        if record is not None:
            samples = {**samples, "rounds": record.rounds, "pairs": record.thermalized_pairs}
        return new, samples

    return jax.lax.scan(body, state, None, length=length)


def prepared(n: int, precision: str, probability, steps: int, equilibration: int):
    """(compiled chunk, equilibrated state) of one scene."""
    simulation = build(scene(n, precision, probability))
    state = driver.run(simulation, simulation.init_fn(), equilibration, equilibration)
    state = simulation.reallocate(state, None)
    compiled = _chunk_with_rounds.lower(simulation.step_fn, state, steps).compile()
    (state, _), _ = timed(compiled, state)  # warm-up
    return compiled, state


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sizes", type=int, nargs="+", default=[3000, 12000])
    parser.add_argument("--probabilities", type=float, nargs="+", default=[0.1, 0.5, 1.0])
    parser.add_argument("--steps", type=int, default=100)
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--equilibration", type=int, default=300)
    parser.add_argument("--precision", default="float32")
    args = parser.parse_args()
    rows = []
    for n in args.sizes:
        cases = [None, *args.probabilities]
        prepared_cases = {
            p: prepared(n, args.precision, p, args.steps, args.equilibration) for p in cases
        }
        best = dict.fromkeys(cases, np.inf)
        samples = {}
        for _ in range(args.repeats):
            for p in cases:
                compiled, state = prepared_cases[p]
                (state, samples[p]), seconds = timed(compiled, state)
                prepared_cases[p] = (compiled, state)
                best[p] = min(best[p], seconds / args.steps)
        for p in cases:
            row = {
                "N": n,
                "thermostat": "groot_warren" if p is None else "lowe_andersen",
                "probability": p,
                "ms_per_step": 1e3 * best[p],
                "cost_vs_groot_warren": best[p] / best[None],
                "temperature": float(np.mean(temperature(samples[p]["kinetic"], n))),
            }
            if p is not None:
                rounds = np.asarray(samples[p]["rounds"])
                pairs = np.asarray(samples[p]["pairs"])
                row.update(
                    rounds_mean=float(rounds.mean()),
                    rounds_max=int(rounds.max()),
                    pairs_per_step=float(pairs.mean()),
                    pairs_per_particle=float(2 * pairs.mean() / n),
                )
            rows.append(row)
            print_table(list(row), [row])
    columns = [
        "N",
        "thermostat",
        "probability",
        "ms_per_step",
        "cost_vs_groot_warren",
        "rounds_mean",
        "rounds_max",
        "pairs_per_particle",
        "temperature",
    ]
    print()
    print_table(columns, rows)
    payload = {
        "precision": args.precision,
        "steps": args.steps,
        "dt": DT,
        "density": DENSITY,
        "peak_rss_mib": peak_rss_mib(),
        "rows": rows,
    }
    print(f"wrote {write_json('lowe_andersen_cost', payload)}")


if __name__ == "__main__":
    jax.config.update("jax_enable_x64", True)
    main()
