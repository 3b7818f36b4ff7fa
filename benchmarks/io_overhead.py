"""Cost of streaming a run to H5MD: the same run with and without an output file.

FENE dumbbells in the demo's Groot–Warren DPD solvent (_common.dumbbell_demo), with
the heaviest output: per-step temperature, pressure tensor and ⟨Q²⟩, g(r), and a
frame (positions, velocities, images) and a checkpoint at every chunk.  The scene is
compiled by a warm-up run; then runs without and with a file alternate, and the
ratio of their wall times is taken within this one process (the machine may be
shared: absolute times are noisy, the ratio less so).

Usage: python benchmarks/io_overhead.py [--count 3000] [--steps 500] [--chunk 100]
       [--repeats 2]
Writes benchmarks/results/io_overhead.json.
"""

import argparse
import tempfile
from pathlib import Path

from _common import dumbbell_demo, peak_rss_mib, print_table, write_json

from jaxdpd.run.runner import simulate


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--count", type=int, default=3000)
    parser.add_argument("--steps", type=int, default=500)
    parser.add_argument("--chunk", type=int, default=100)
    parser.add_argument("--repeats", type=int, default=2)
    args = parser.parse_args()
    scene = dumbbell_demo(args.count).replace(
        run={"steps": args.steps, "chunk": args.chunk, "equilibration": 0},
        output={"trajectory_every": args.chunk, "checkpoint_every": args.chunk},
    )
    folder = Path(tempfile.mkdtemp(prefix="jaxdpd-io-"))
    simulate(scene, None, progress=False)  # compile
    times = {"no file": [], "H5MD file": []}
    for repeat in range(args.repeats):
        for label, path in (("no file", None), ("H5MD file", folder / f"run{repeat}.h5")):
            times[label].append(simulate(scene, path, progress=False).wall_seconds)
    size = (folder / "run0.h5").stat().st_size
    base = min(times["no file"])
    rows = [
        {
            "output": label,
            "best_wall_s": min(seconds),
            "ratio": min(seconds) / base,
            "per_chunk_ms": 1e3 * (min(seconds) - base) / (args.steps // args.chunk),
        }
        for label, seconds in times.items()
    ]
    print_table(list(rows[0]), rows)
    print(f"file size {size / 2**20:.1f} MiB for {args.steps // args.chunk} frames + checkpoints")
    path = write_json(
        "io_overhead",
        {"arguments": vars(args), "rows": rows, "file_bytes": size, "peak_rss_mib": peak_rss_mib()},
    )
    print(f"wrote {path}")


if __name__ == "__main__":
    main()
