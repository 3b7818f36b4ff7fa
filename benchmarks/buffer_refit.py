"""What the driver's buffer refit is worth on the path users run.

A user builds a scene, calls `init_fn()` (a random start) and then `driver.run`
chunk after chunk.  The neighbour buffers sized for the random start hold twice the
cell slots a liquid needs; since the driver refits buffers that have grown far
larger than the state needs (`driver.SHRINK_BELOW`), a run no longer keeps paying
for its start.  This script times that user path twice in one process, with the
refit on (as shipped) and off (`SHRINK_BELOW = 0`, the behaviour before it), the
two alternating chunk by chunk after the same equilibration, and reports the best
chunk of each, their ratio and the cell capacity each ran with.

System: the Groot–Warren fluid of benchmarks/dpd_throughput.py (ρ = 3, a = 25,
γ = 4.5, Δt = 0.04, λ = 0.5, float32, temperature and pressure sampled every step).

Usage:
    python benchmarks/buffer_refit.py [--sizes 3000 24000] [--steps 100]
        [--equilibration 200] [--rounds 4]
Writes benchmarks/results/buffer_refit.json.
"""

import argparse
import time

import jax
from _common import print_table, write_json
from dpd_throughput import fluid_scene

from jaxdpd.engine.build import build
from jaxdpd.run import driver


def user_run(simulation, state, steps: int, refit: bool):
    """One `driver.run` call of `steps` steps, with or without the buffer refit;
    (state, wall seconds)."""
    shrink_below = driver.SHRINK_BELOW
    driver.SHRINK_BELOW = shrink_below if refit else 0.0
    try:
        start = time.perf_counter()
        state = jax.block_until_ready(driver.run(simulation, state, steps, steps))
        return state, time.perf_counter() - start
    finally:
        driver.SHRINK_BELOW = shrink_below


def measure(n: int, steps: int, equilibration: int, rounds: int) -> dict:
    simulation = build(fluid_scene(n, "float32"))
    start = simulation.init_fn()
    states = {}
    for refit in (True, False):
        state = start
        for _ in range(max(1, equilibration // steps) + 1):  # the last call compiles
            state, _ = user_run(simulation, state, steps, refit)
        states[refit] = state
    seconds = {True: [], False: []}
    for _ in range(rounds):
        for refit in (True, False):
            states[refit], elapsed = user_run(simulation, states[refit], steps, refit)
            seconds[refit].append(elapsed)
    rates = {refit: n * steps / min(values) for refit, values in seconds.items()}
    return {
        "N": n,
        "refit_particle_steps_per_s": rates[True],
        "no_refit_particle_steps_per_s": rates[False],
        "ratio": rates[True] / rates[False],
        "refit_cell_capacity": states[True].pair_list.cell_capacity,
        "no_refit_cell_capacity": states[False].pair_list.cell_capacity,
        "start_cell_capacity": start.pair_list.cell_capacity,
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sizes", type=int, nargs="+", default=[3000, 24000])
    parser.add_argument("--steps", type=int, default=100)
    parser.add_argument("--equilibration", type=int, default=200)
    parser.add_argument("--rounds", type=int, default=4)
    args = parser.parse_args()
    rows = [measure(n, args.steps, args.equilibration, args.rounds) for n in args.sizes]
    print_table(list(rows[0]), rows)
    print(f"wrote {write_json('buffer_refit', {'steps': args.steps, 'rows': rows})}")


if __name__ == "__main__":
    jax.config.update("jax_enable_x64", True)  # float32 scenes stay float32
    main()
