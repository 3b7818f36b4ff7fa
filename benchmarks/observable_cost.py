"""What recording the pressure tensor costs: a DPD step with and without the virial.

The fluid of `dpd_throughput.py` (ρ = 3, a = 25, γ = 4.5, Δt = 0.04, float32, cell
list rebuilt every step) is built twice in one process, recording "temperature"
alone and "temperature" with "pressure" (the virial of every pair law, thesis eq.
3.46).  Both start from the same state, so they follow the same trajectory (the
virial does not act on the dynamics); each is equilibrated and its buffers fitted.
Their compiled chunks are then timed alternately, `--rounds` times, and the best of
each counts: alternating spreads the machine's drift over both variants, which
between processes differs by up to 15 % on a shared machine.

Usage: python benchmarks/observable_cost.py [--sizes 3000 24000 96000] [--steps 50]
    [--rounds 5]
Writes benchmarks/results/observable_cost.json.
"""

import argparse

from _common import print_table, timed, write_json
from dpd_throughput import equilibrated_fluid

from jaxdpd.run import driver

VARIANTS = {"temperature": ("temperature",), "temperature+pressure": ("temperature", "pressure")}


def equilibrated_chunk(n: int, observables, steps: int, equilibration: int):
    """(compiled chunk of `steps` steps, equilibrated state with fitted buffers)."""
    simulation, state = equilibrated_fluid(n, observables, equilibration, steps)
    return driver._scan_chunk.lower(simulation.step_fn, state, steps).compile(), state


def compare(n: int, steps: int, rounds: int, equilibration: int) -> dict:
    chunks = {
        name: equilibrated_chunk(n, obs, steps, equilibration) for name, obs in VARIANTS.items()
    }
    best = dict.fromkeys(chunks, float("inf"))
    for _ in range(rounds):
        for name, (compiled, state) in chunks.items():
            _, seconds = timed(compiled, state)
            best[name] = min(best[name], seconds)
    row = {"N": n}
    for name, seconds in best.items():
        row[f"{name} ns/particle-step"] = 1e9 * seconds / (n * steps)
    row["pressure_cost_ratio"] = best["temperature+pressure"] / best["temperature"]
    return row


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sizes", type=int, nargs="+", default=[3000, 24000, 96000])
    parser.add_argument("--steps", type=int, default=50)
    parser.add_argument("--rounds", type=int, default=5)
    parser.add_argument("--equilibration", type=int, default=300)
    args = parser.parse_args()
    rows = [compare(n, args.steps, args.rounds, args.equilibration) for n in args.sizes]
    print_table(list(rows[0]), rows)
    print("wrote", write_json("observable_cost", {"steps": args.steps, "rows": rows}))


if __name__ == "__main__":
    main()
