"""What survives a kill -9: three ways of keeping a checkpoint beside an H5MD run.

A child process writes like a jaxdpd run with a checkpoint at every chunk: per chunk
it appends 100 samples to three chunked, Fletcher-32 series and a frame of N
particles (positions, velocities) to the output file, flushes it, and checkpoints a
state of three (N, 3) float64 arrays (CRC-32 per leaf) that depends on the chunk
number.  The parent kills it with SIGKILL at a random instant (uniform in
[--earliest, --latest] s after it starts writing) and then checks what is left:

- "in place":   the checkpoint group inside the output file, overwritten, with a
                `complete` flag (jaxdpd before issue 28);
- "two slots":  two groups inside the output file written alternately, an attribute
                naming the valid one flipped (and flushed) last;
- "own file":   jaxdpd.io.checkpoint: the output flushed and fsynced, the checkpoint
                written to a temporary file, fsynced, renamed over the previous one.

Counted per mode: kills before the first checkpoint, runs whose checkpoint is lost
(unreadable, incomplete or failing a checksum), runs whose output file no longer
opens or reads; and the time one checkpoint write takes (in this process, best of
--repeats).

Usage: python benchmarks/checkpoint_survival.py [--trials 40] [--count 3000]
Writes benchmarks/results/checkpoint_survival.json.
"""

import argparse
import os
import random
import signal
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import NamedTuple

import h5py
import numpy as np
from _common import print_table, write_json

from jaxdpd.io import checkpoint
from jaxdpd.io.pytree_store import read_leaf, stored_leaf_names, write_tree

MODES = ("in place", "two slots", "own file")


class State(NamedTuple):
    positions: np.ndarray
    velocities: np.ndarray
    forces: np.ndarray
    step: np.ndarray
    time: np.ndarray


def make_state(chunk: int, count: int) -> State:
    values = np.full((count, 3), float(chunk))
    return State(values, values + 1, values + 2, np.asarray(chunk), np.asarray(chunk * 0.04))


def write_state(handle, mode: str, state: State) -> None:
    """One checkpoint of `state` in `mode` (the output file `handle` is flushed)."""
    if mode == "in place":
        group = handle.require_group("checkpoint")
        group.attrs["complete"] = False
        write_tree(group.require_group("state"), state)
        group.attrs["complete"] = True
        handle.flush()
    elif mode == "two slots":
        group = handle.require_group("checkpoint")
        slot = "b" if group.attrs.get("current") == "a" else "a"
        write_tree(group.require_group(slot), state)
        handle.flush()
        group.attrs["current"] = slot
        handle.flush()
    else:
        handle.flush()
        os.fsync(handle.id.get_vfd_handle())
        checkpoint.write_checkpoint(
            checkpoint.checkpoint_path(handle.filename), state, "production", "periodic", "", {}, {}
        )


def child(mode: str, folder: Path, count: int) -> None:
    """Write chunks and checkpoints until killed."""
    handle = h5py.File(folder / "run.h5", "w")
    for name, shape in (("a", ()), ("b", (3, 3)), ("c", ()), ("frame", (count, 3))):
        length = 100 if name != "frame" else 1
        handle.create_dataset(
            name,
            (0, *shape),
            "f8",
            maxshape=(None, *shape),
            chunks=(max(1, 8192 // max(1, int(np.prod(shape)))), *shape),
            fletcher32=True,
        ).attrs["per_chunk"] = length
    handle.flush()
    print("ready", flush=True)
    chunk = 0
    while True:
        chunk += 1
        for name in ("a", "b", "c", "frame"):
            dataset = handle[name]
            rows = dataset.attrs["per_chunk"]
            dataset.resize(dataset.shape[0] + rows, axis=0)
            dataset[-rows:] = chunk
        handle.flush()
        write_state(handle, mode, make_state(chunk, count))


def read_state(path: Path, mode: str):
    """The checkpoint's step, or None when none is there; raises when it is damaged."""
    if mode == "own file":
        if not checkpoint.checkpoint_path(path).exists():
            return None
        return int(checkpoint.read_checkpoint_leaves(path)["step"])
    with h5py.File(path, "r") as handle:
        if "checkpoint" not in handle:
            return None
        group = handle["checkpoint"]
        if mode == "in place":
            if not group.attrs["complete"]:
                raise ValueError("incomplete")
            state = group["state"]
        else:
            if "current" not in group.attrs:
                return None
            state = group[group.attrs["current"]]
        leaves = {name: read_leaf(state, name) for name in stored_leaf_names(state)}
        step = int(leaves["step"])
        if not np.all(leaves["positions"] == step):
            raise ValueError("positions of another step")
        return step


def output_readable(path: Path) -> bool:
    try:
        with h5py.File(path, "r") as handle:
            for name in ("a", "b", "c", "frame"):
                if handle[name].shape[0]:
                    handle[name][-1]
        return True
    except Exception:  # noqa: BLE001 - any failure counts as unreadable
        return False


def trial(mode: str, count: int, delay: float) -> dict:
    with tempfile.TemporaryDirectory(prefix="jaxdpd-survival-") as folder:
        process = subprocess.Popen(
            [sys.executable, __file__, "--child", mode, "--folder", folder, "--count", str(count)],
            stdout=subprocess.PIPE,
        )
        assert process.stdout.readline().strip() == b"ready"
        time.sleep(delay)
        process.send_signal(signal.SIGKILL)
        process.wait()
        path = Path(folder) / "run.h5"
        try:
            step, lost = read_state(path, mode), False
        except Exception:  # noqa: BLE001 - any failure to read it back is a loss
            step, lost = None, True
        readable = output_readable(path)
    return {"none_yet": step is None and not lost, "lost": lost, "readable": readable}


def write_seconds(mode: str, count: int, repeats: int) -> float:
    with tempfile.TemporaryDirectory(prefix="jaxdpd-survival-") as folder:
        with h5py.File(Path(folder) / "run.h5", "w") as handle:
            seconds = []
            for chunk in range(repeats):
                start = time.perf_counter()
                write_state(handle, mode, make_state(chunk, count))
                seconds.append(time.perf_counter() - start)
    return min(seconds)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--trials", type=int, default=40)
    parser.add_argument("--count", type=int, default=3000)
    parser.add_argument("--earliest", type=float, default=0.2)
    parser.add_argument("--latest", type=float, default=1.5)
    parser.add_argument("--repeats", type=int, default=20)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--child", choices=MODES)
    parser.add_argument("--folder")
    args = parser.parse_args()
    if args.child:
        child(args.child, Path(args.folder), args.count)
        return
    generator = random.Random(args.seed)
    rows = []
    for mode in MODES:
        results = [
            trial(mode, args.count, generator.uniform(args.earliest, args.latest))
            for _ in range(args.trials)
        ]
        rows.append(
            {
                "mode": mode,
                "trials": args.trials,
                "killed_before_first": sum(r["none_yet"] for r in results),
                "checkpoint_lost": sum(r["lost"] for r in results),
                "output_unreadable": sum(not r["readable"] for r in results),
                "write_ms": 1e3 * write_seconds(mode, args.count, args.repeats),
            }
        )
        print_table(list(rows[-1]), rows[-1:])
    print_table(list(rows[0]), rows)
    path = write_json("checkpoint_survival", {"arguments": vars(args), "rows": rows})
    print(f"wrote {path}")


if __name__ == "__main__":
    main()
