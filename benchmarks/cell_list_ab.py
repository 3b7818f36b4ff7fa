"""DPD step rate: this tree's cell list against a base tree's, alternating in one process.

The base's `jaxdpd/geometry/neighbors/cell_list.py` is loaded as a separate module
(what it imports is this tree's) and put in place of this tree's cell list while the
base step compiles.  Both run the float32 Groot–Warren fluid of
benchmarks/dpd_throughput.py (temperature and pressure observed) from the same
equilibrated state, with the buffers the driver fitted, in compiled chunks and
alternating rounds; the positions after one chunk are compared bit for bit.

    git worktree add --detach /tmp/base <commit>
    python benchmarks/cell_list_ab.py --base /tmp/base [--sizes 3000 24000] [--rounds 7]
"""

import argparse
import statistics
from pathlib import Path

import numpy as np
from _common import alternating_rates, compiled_chunk, module_from_file, ratio_summary
from dpd_throughput import equilibrated_fluid

from jaxdpd.geometry.neighbors import cell_list


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--base", type=Path, required=True)
    parser.add_argument("--sizes", type=int, nargs="+", default=[3000, 24000])
    parser.add_argument("--steps", type=int, default=50)
    parser.add_argument("--rounds", type=int, default=7)
    args = parser.parse_args()
    base_module = module_from_file(
        args.base / "jaxdpd" / "geometry" / "neighbors" / "cell_list.py", "base_cell_list"
    )
    for n in args.sizes:
        simulation, state = equilibrated_fluid(n)
        replacements = [(cell_list, "cell_list_search", base_module.cell_list_search)]
        runs = {
            "base": compiled_chunk(simulation.scene, state, args.steps, replacements)[0],
            "this": compiled_chunk(simulation.scene, state, args.steps)[0],
        }
        (base_state, _), (this_state, _) = runs["base"](state), runs["this"](state)
        identical = np.array_equal(
            np.asarray(base_state.positions), np.asarray(this_state.positions)
        )
        rates = alternating_rates(
            {name: lambda c=chunk, s=state: c(s) for name, chunk in runs.items()},
            n * args.steps,
            args.rounds,
        )
        print(
            f"N = {n}: positions after {args.steps} steps bit-identical: {identical}; "
            f"base {statistics.median(rates['base']):.3g}, this "
            f"{statistics.median(rates['this']):.3g} particle-steps/s, {ratio_summary(rates)}",
            flush=True,
        )


if __name__ == "__main__":
    main()
