"""Cost of one checkpoint of the demo scene: the output flushed and fsynced, the
checkpoint file built in memory, written, fsynced and renamed (jaxdpd.io.checkpoint).

The state is that of FENE dumbbells in the demo's DPD solvent (float32, on-device
chain correlators; _common.dumbbell_demo) at --count particles, as drawn by init_fn:
a checkpoint's size and cost do not depend on the configuration.  Nothing is compiled.

Usage: python benchmarks/checkpoint_cost.py [--count 3000] [--repeats 8]
Writes benchmarks/results/checkpoint_cost.json.
"""

import argparse
import tempfile
import time
from pathlib import Path

from _common import dumbbell_demo, print_table, write_json

from jaxdpd.engine.build import build
from jaxdpd.io.checkpoint import checkpoint_path
from jaxdpd.io.h5md import H5MDWriter


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--count", type=int, default=3000)
    parser.add_argument("--repeats", type=int, default=8)
    args = parser.parse_args()
    scene = dumbbell_demo(args.count)
    simulation = build(scene)
    state = simulation.init_observers(simulation.init_fn())
    with tempfile.TemporaryDirectory(prefix="jaxdpd-checkpoint-") as folder:
        path = Path(folder) / "run.h5"
        writer = H5MDWriter.create(path, scene, simulation.blocks)
        seconds = []
        for _ in range(args.repeats):
            start = time.perf_counter()
            writer.write_checkpoint(state, "production", "periodic", {})
            seconds.append(time.perf_counter() - start)
        writer.close()
        size = checkpoint_path(path).stat().st_size
    seconds.sort()
    row = {
        "particles": args.count,
        "checkpoint_mib": size / 2**20,
        "best_ms": 1e3 * seconds[0],
        "median_ms": 1e3 * seconds[len(seconds) // 2],
    }
    print_table(list(row), [row])
    path = write_json("checkpoint_cost", {"arguments": vars(args), "rows": [row]})
    print(f"wrote {path}")


if __name__ == "__main__":
    main()
