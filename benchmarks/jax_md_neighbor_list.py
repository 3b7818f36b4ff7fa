"""jax-md's `simulate.nve` with jaxdpd's cell list against jax-md's own neighbour list.

One periodic soft-sphere fluid (jax-md's `energy.soft_sphere_neighbor_list` with
α = 2, σ = 1, ε = 25: the DPD conservative force at a = 25), ρ = 3, uniform random
start, velocities at k_BT = 1, cut-off 1, skin 0.3, Δt = 0.02,
stepped by the same jitted loop of `simulate.nve` with a neighbour update per step;
only the list differs: jaxdpd.interop.jax_md.neighbor_list or
jax_md.partition.neighbor_list (same format, same rebuild rule: a particle moved more
than half the skin).  The two are timed alternately in one process, `--rounds` times
each, and the median ratio is reported; the machine is shared, so single figures are
noisy and only the same-run ratio means much.

Usage: python benchmarks/jax_md_neighbor_list.py [--sizes 3000] [--steps 200]
       [--rounds 5] [--format ordered_sparse]
Writes benchmarks/results/jax_md_neighbor_list_<format>.json.
"""

import argparse
import statistics

import jax
import jax.numpy as jnp
import numpy as np
from _common import print_table, timed, write_json
from jax_md import energy, partition, simulate
from jax_md import space as jmd_space

import jaxdpd
from jaxdpd.geometry.boxes import PeriodicBox
from jaxdpd.interop.jax_md import neighbor_list, space

FORMATS = {
    "ordered_sparse": partition.OrderedSparse,
    "sparse": partition.Sparse,
    "dense": partition.Dense,
}
CUTOFF, SKIN, DT, DENSITY, A = 1.0, 0.3, 0.02, 3.0, 25.0


def runner(displacement, shift, neighbor_fns, positions, steps: int):
    """(run, state, neighbors): `run(state, neighbors)` takes `steps` NVE steps."""
    _, energy_fn = energy.soft_sphere_neighbor_list(
        displacement, 1.0, sigma=CUTOFF, epsilon=A, alpha=2.0
    )
    init_fn, apply_fn = simulate.nve(energy_fn, shift, DT)
    neighbors = neighbor_fns.allocate(positions)
    state = init_fn(jax.random.PRNGKey(0), positions, kT=1.0, neighbor=neighbors)

    @jax.jit
    def run(state, neighbors):
        def body(_, carry):
            state, neighbors = carry
            neighbors = neighbor_fns.update(state.position, neighbors)
            return apply_fn(state, neighbor=neighbors), neighbors

        return jax.lax.fori_loop(0, steps, body, (state, neighbors))

    return run, state, neighbors


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sizes", type=int, nargs="+", default=[3000])
    parser.add_argument("--steps", type=int, default=200)
    parser.add_argument("--rounds", type=int, default=5)
    parser.add_argument("--format", choices=sorted(FORMATS), default="ordered_sparse")
    args = parser.parse_args()
    # jaxdpd's cell list packs rows into uint64 words; switch 64-bit types on before
    # either list is built, so both runs compile in the same mode (float32 arrays).
    jaxdpd.enable_float64()
    fmt = FORMATS[args.format]
    rows = []
    for n in args.sizes:
        side = (n / DENSITY) ** (1 / 3)
        sides = jnp.full(3, side, jnp.float32)
        positions = jnp.asarray(np.random.default_rng(0).uniform(0, side, (n, 3)), jnp.float32)
        jax_md_space = jmd_space.periodic(sides)
        jax_md_list = partition.neighbor_list(
            jax_md_space[0], sides, CUTOFF, dr_threshold=SKIN, format=fmt
        )
        box = PeriodicBox((side, side, side))
        jaxdpd_list = neighbor_list(box, CUTOFF, dr_threshold=SKIN, format=fmt)
        runs = {
            "jax_md": runner(*jax_md_space, jax_md_list, positions, args.steps),
            "jaxdpd": runner(*space(box), jaxdpd_list, positions, args.steps),
        }
        seconds = {name: [] for name in runs}
        for run, state, neighbors in runs.values():
            timed(run, state, neighbors)  # compile
        for _ in range(args.rounds):
            for name, (run, state, neighbors) in runs.items():
                (_, neighbors_out), elapsed = timed(run, state, neighbors)
                if neighbors_out.did_buffer_overflow:
                    raise RuntimeError(f"{name}: neighbour list overflowed; raise the capacity")
                seconds[name].append(elapsed / args.steps)
        medians = {name: statistics.median(v) for name, v in seconds.items()}
        rows.append(
            {
                "N": n,
                "format": args.format,
                "jax_md_ms_per_step": 1e3 * medians["jax_md"],
                "jaxdpd_ms_per_step": 1e3 * medians["jaxdpd"],
                "speedup": medians["jax_md"] / medians["jaxdpd"],
                "ratios_per_round": [
                    a / b for a, b in zip(seconds["jax_md"], seconds["jaxdpd"], strict=True)
                ],
            }
        )
    columns = ["N", "format", "jax_md_ms_per_step", "jaxdpd_ms_per_step", "speedup"]
    print_table(columns, rows)
    print("(shared, noisy machine: compare the same-run ratio, not the absolute times)")
    path = write_json(f"jax_md_neighbor_list_{args.format}", {"args": vars(args), "rows": rows})
    print(f"wrote {path}")


if __name__ == "__main__":
    main()
