"""MPCD step rate: this tree's collision against a base tree's, alternating in one process.

The base's SRD collision, cell binning and kinetic tensor
(`jaxdpd/solvents/mpcd/collision.py`, `cells.py`, `jaxdpd/observables/thermo.py`) are
loaded as separate modules (what they import is this tree's, except the collision's
sine and cosine, `jaxdpd/trigonometry.py`, also the base's) and put in place of this
tree's while the base step compiles.  Both run the scene of
benchmarks/mpcd_throughput.py (ρ = 10, α = 130°, h = 0.1, temperature observed) in
compiled chunks, in alternating rounds; the velocities after one chunk from the same
state are compared bit for bit.

    git worktree add --detach /tmp/base <commit>
    python benchmarks/mpcd_ab.py --base /tmp/base [--size 100000] [--rounds 6]
"""

import argparse
import statistics
from pathlib import Path

import numpy as np
from _common import alternating_rates, compiled_chunk, module_from_file, ratio_summary
from mpcd_throughput import solvent_scene

from jaxdpd.observables import thermo as thermo_module
from jaxdpd.solvents.mpcd import step as mpcd_step_module


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--base", type=Path, required=True)
    parser.add_argument("--size", type=int, default=100_000)
    parser.add_argument("--precision", default="float32")
    parser.add_argument("--steps", type=int, default=20)
    parser.add_argument("--rounds", type=int, default=6)
    args = parser.parse_args()
    scene = solvent_scene(args.size, args.precision)
    base_mpcd = args.base / "jaxdpd" / "solvents" / "mpcd"
    base_collision = module_from_file(base_mpcd / "collision.py", "base_mpcd_collision")
    base_cells = module_from_file(base_mpcd / "cells.py", "base_mpcd_cells")
    base_trigonometry = module_from_file(
        args.base / "jaxdpd" / "trigonometry.py", "base_trigonometry"
    )
    base_collision.sincos_turns = base_trigonometry.sincos_turns
    base_thermo = module_from_file(
        args.base / "jaxdpd" / "observables" / "thermo.py", "base_thermo"
    )
    replacements = [
        (mpcd_step_module, "srd_collision", base_collision.srd_collision),
        (mpcd_step_module, "bin_particles", base_cells.bin_particles),
        (thermo_module, "kinetic_tensor", base_thermo.kinetic_tensor),
    ]
    base_chunk, _ = compiled_chunk(scene, None, args.steps, replacements)
    this_chunk, state = compiled_chunk(scene, None, args.steps)
    runs = {"base": base_chunk, "this": this_chunk}
    (base_state, _), (this_state, _) = runs["base"](state), runs["this"](state)
    identical = np.array_equal(np.asarray(base_state.velocities), np.asarray(this_state.velocities))
    n = scene.n_particles
    rates = alternating_rates(
        {name: lambda chunk=chunk: chunk(state) for name, chunk in runs.items()},
        n * args.steps,
        args.rounds,
    )
    print(
        f"N = {n} {args.precision}: velocities after {args.steps} steps bit-identical: "
        f"{identical}; base {statistics.median(rates['base']):.3g}/s, this "
        f"{statistics.median(rates['this']):.3g}/s, {ratio_summary(rates)}"
    )


if __name__ == "__main__":
    main()
