"""Where a DPD step's time goes: the neighbour rebuild against everything else.

The Groot–Warren fluid of `dpd_throughput.py` (ρ = 3, a = 25, γ = 4.5, Δt = 0.04,
float32, skin 0, so the cell list is rebuilt every step), equilibrated and with its
buffers fitted.  Timed in one process, best of `--repeats`: a chunk of `--steps`
steps, and the same number of rebuilds alone (`neighbor_search.update` on the
chunk's start positions, nudged every call so that nothing is hoisted out of the
loop).  "rest" is the difference: forces, noise, integrator and observables.

Usage: python benchmarks/step_split.py [--sizes 3000 24000 96000] [--steps 50]
Writes benchmarks/results/step_split.json.
"""

import argparse

import jax
import jax.numpy as jnp
from _common import print_table, timed, write_json
from dpd_throughput import equilibrated_fluid

from jaxdpd.run import driver


def best_seconds(function, argument, repeats: int) -> float:
    """Fastest of `repeats` calls after one warm-up (compilation) call."""
    timed(function, argument)
    return min(timed(function, argument)[1] for _ in range(repeats))


def split(n: int, steps: int, repeats: int) -> dict:
    simulation, state = equilibrated_fluid(n)
    chunk = jax.jit(lambda s: driver._scan_chunk(simulation.step_fn, s, steps))
    step = best_seconds(chunk, state, repeats) / steps
    search = simulation.neighbor_search

    def rebuilds(start):
        def body(k, carry):
            positions, pair_list = carry
            positions = positions + jnp.asarray(1e-7, positions.dtype) * jnp.sin(positions * k)
            return positions, search.update(positions, pair_list, state.box_state)

        return jax.lax.fori_loop(0, steps, body, (start.positions, start.pair_list))[1]

    rebuild = best_seconds(jax.jit(rebuilds), state, repeats) / steps
    return {
        "N": n,
        "step_ms": 1e3 * step,
        "rebuild_ms": 1e3 * rebuild,
        "rest_ms": 1e3 * (step - rebuild),
        "rebuild_share": rebuild / step,
        "rebuild_ns_per_particle": 1e9 * rebuild / n,
        "rest_ns_per_particle": 1e9 * (step - rebuild) / n,
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sizes", type=int, nargs="+", default=[3000, 24000, 96000])
    parser.add_argument("--steps", type=int, default=50)
    parser.add_argument("--repeats", type=int, default=5)
    args = parser.parse_args()
    rows = [split(n, args.steps, args.repeats) for n in args.sizes]
    print_table(list(rows[0]), rows)
    print("wrote", write_json("step_split", {"rows": rows}))


if __name__ == "__main__":
    main()
