"""Throughput of this checkout against an earlier revision, measured alternately.

Refactors must not cost speed.  This script checks out `--base` into a temporary
git worktree and runs the same throughput benchmarks (DPD fluid, lattice-Boltzmann
lattice and chain, MPCD fluid) in both trees, alternating base and head round after
round (which goes first alternates too) so that a machine whose load drifts affects
both alike; each benchmark run is a fresh process using its own tree's code
(`PYTHONPATH`).  It reports, per figure, the best of the rounds for each tree, their
ratio head/base, and each round's ratio: their spread is the noise a difference must
exceed to mean anything.

With `--compiled` it times nothing: it compiles the DPD chunk of each tree (float32,
N = 24000 and 3000, buffers fitted after equilibration) and compares the optimised
XLA programs instruction by instruction, names and source locations removed, and the
state's buffer shapes.  Identical programs on identical buffers run at the same speed,
whatever a noisy machine's timings say.

Usage:
    python benchmarks/revision_throughput.py --base c87a54c [--rounds 3] [--compiled]
Writes benchmarks/results/revision_throughput.json (timings only).
"""

import argparse
import difflib
import json
import os
import re
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


COMPILED_SIZES = (3000, 24000)


def compiled_dpd_program(n: int) -> str:
    """The optimised program of this interpreter's tree's DPD chunk at N = n, with
    instruction names, metadata and source tables removed, then its state's shapes."""
    import jax

    sys.path.insert(0, os.getcwd())  # this tree's benchmarks, ahead of the script's own
    from dpd_throughput import JaxdpdFluid

    fluid = JaxdpdFluid(n, "float32", 100, 200)
    lines = []
    for line in fluid.compiled.as_text().splitlines():
        line = re.sub(r",? ?(metadata=\{[^}]*\}|stack_frame_id=\d+)", "", line)
        # Instructions and computation headers; not the source-location tables.
        if re.match(r"\s*\d+ ", line) is None and (" = " in line or line.endswith("{")):
            lines.append(re.sub(r"[._]\d+\b", "", line))
    shapes = [
        f"{jax.tree_util.keystr(path)} {leaf.shape} {leaf.dtype}"
        for path, leaf in jax.tree_util.tree_leaves_with_path(fluid.state)
    ]
    return "\n".join(lines + shapes)


def compare_compiled(base_tree: Path) -> list[dict]:
    """Per size, whether the base and head DPD programs are identical."""
    rows = []
    for n in COMPILED_SIZES:
        programs = {}
        for label, tree in (("base", base_tree), ("head", REPOSITORY)):
            programs[label] = subprocess.run(
                [sys.executable, str(Path(__file__).resolve()), "--print-compiled", str(n)],
                cwd=tree / "benchmarks",
                env={**os.environ, "PYTHONPATH": str(tree)},
                check=True,
                capture_output=True,
                text=True,
            ).stdout.splitlines()
        differing = sum(
            line[0] in "+-" and line[:3] not in ("+++", "---")
            for line in difflib.unified_diff(programs["base"], programs["head"], n=0)
        )
        rows.append(
            {
                "figure": f"DPD N={n} compiled chunk",
                "base lines": len(programs["base"]),
                "head lines": len(programs["head"]),
                "differing lines": differing,
            }
        )
    return rows


def revisions(base: str) -> dict:
    """The compared revisions as commits: `base` as given and resolved, HEAD, and
    whether the working tree (which is what "head" times) had uncommitted changes."""

    def git(*arguments) -> str:
        return subprocess.run(
            ["git", *arguments], cwd=REPOSITORY, check=True, capture_output=True, text=True
        ).stdout.strip()

    return {
        "base": base,
        "base_commit": git("rev-parse", base),
        "head_commit": git("rev-parse", "HEAD"),
        "head_uncommitted_changes": bool(git("status", "--porcelain", "--untracked-files=no")),
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--base", help="git revision to compare against (required)")
    parser.add_argument("--rounds", type=int, default=3)
    parser.add_argument(
        "--compiled", action="store_true", help="compare compiled DPD programs, time nothing"
    )
    parser.add_argument("--print-compiled", type=int, help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.print_compiled:  # the child of --compiled, running in one tree
        print(compiled_dpd_program(args.print_compiled))
        return
    if args.base is None:
        parser.error("--base: give the git revision to compare against")
    with tempfile.TemporaryDirectory() as scratch:
        base_tree = Path(scratch) / "base"
        subprocess.run(
            ["git", "worktree", "add", "--detach", str(base_tree), args.base],
            cwd=REPOSITORY,
            check=True,
            capture_output=True,
        )
        try:
            if args.compiled:
                rows = compare_compiled(base_tree)
                print_table(list(rows[0]), rows)
                return
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
    path = write_json("revision_throughput", {**revisions(args.base), "rounds": rows})
    print(f"wrote {path}")


if __name__ == "__main__":
    main()
