"""Throughput of this checkout against an earlier revision, measured alternately.

Refactors must not cost speed.  This script checks out `--base` into a temporary
git worktree and runs the same throughput benchmarks (DPD fluid, lattice-Boltzmann
lattice and chain, MPCD fluid) in both trees, alternating base and head round after
round (which goes first alternates too) so that a machine whose load drifts affects
both alike; each benchmark run is a fresh process using its own tree's code
(`PYTHONPATH`).  It reports, per figure, the best of the rounds for each tree, their
ratio head/base, and each round's ratio: their spread is the noise a difference must
exceed to mean anything.

Usage:
    python benchmarks/revision_throughput.py --base c87a54c [--rounds 3]
Writes benchmarks/results/revision_throughput.json.
"""

import argparse
import json
import os
import subprocess
import sys
import tempfile
from pathlib import Path

from _common import print_table, write_json

HERE = Path(__file__).resolve().parent
REPOSITORY = HERE.parent

# (benchmark script and arguments, results file, (figure name, row path, value key)).
BENCHMARKS = (
    (
        ["dpd_throughput.py", "--sizes", "3000", "24000", "--precisions", "float32"],
        "dpd_throughput",
        lambda result: {
            f"DPD N={row['N']} particle-steps/s": row["particle_steps_per_s"]
            for row in result["rows"]
        },
    ),
    (
        ["lattice_boltzmann_throughput.py", "--sizes", "32", "--precisions", "float32"],
        "lattice_boltzmann_throughput",
        lambda result: {
            **{f"LB {row['nodes']} nodes MLUPS": row["MLUPS"] for row in result["lattice"]},
            **{
                f"LB chain {row['precision']} bead-steps/s": row["bead_steps_per_s"]
                for row in result["chain"]
            },
        },
    ),
    (
        ["mpcd_throughput.py", "--sizes", "100000", "--precisions", "float32"],
        "mpcd_throughput",
        lambda result: {
            f"MPCD N={row['N']} collisions/s": row["particle_collisions_per_s"]
            for row in result["rows"]
            if row["code"] == "jaxdpd"
        },
    ),
)


def measure(tree: Path) -> dict:
    """Run every benchmark once in `tree`; {figure: value}."""
    figures = {}
    environment = {**os.environ, "PYTHONPATH": str(tree)}
    for command, result_name, read in BENCHMARKS:
        script = tree / "benchmarks" / command[0]
        results = tree / "benchmarks" / "results" / f"{result_name}.json"
        kept = results.read_text() if results.exists() else None  # the published figures
        subprocess.run(
            [sys.executable, str(script), *command[1:]],
            cwd=tree,
            env=environment,
            check=True,
            stdout=subprocess.DEVNULL,
        )
        figures.update(read(json.loads(results.read_text())))
        if kept is not None:
            results.write_text(kept)
    return figures


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--base", required=True, help="git revision to compare against")
    parser.add_argument("--rounds", type=int, default=3)
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as scratch:
        base_tree = Path(scratch) / "base"
        subprocess.run(
            ["git", "worktree", "add", "--detach", str(base_tree), args.base],
            cwd=REPOSITORY,
            check=True,
            capture_output=True,
        )
        try:
            best = {"base": {}, "head": {}}
            ratios = {}  # figure -> head/base of each round
            trees = [("base", base_tree), ("head", REPOSITORY)]
            for round_number in range(args.rounds):
                figures = {}
                # Alternate which tree goes first, so that a drifting load favours neither.
                for label, tree in trees if round_number % 2 == 0 else trees[::-1]:
                    figures[label] = measure(tree)
                    for name, value in figures[label].items():
                        best[label][name] = max(value, best[label].get(name, 0.0))
                for name, value in figures["head"].items():
                    ratios.setdefault(name, []).append(value / figures["base"][name])
                print(f"round {round_number + 1}/{args.rounds} done", flush=True)
        finally:
            subprocess.run(
                ["git", "worktree", "remove", "--force", str(base_tree)],
                cwd=REPOSITORY,
                check=True,
            )
    rows = [
        {
            "figure": name,
            "base": best["base"][name],
            "head": best["head"][name],
            "head/base": best["head"][name] / best["base"][name],
            "round ratios": " ".join(f"{ratio:.3f}" for ratio in ratios[name]),
        }
        for name in best["base"]
    ]
    print_table(["figure", "base", "head", "head/base", "round ratios"], rows)
    path = write_json("revision_throughput", {"base": args.base, "rounds": rows})
    print(f"wrote {path}")


if __name__ == "__main__":
    main()
