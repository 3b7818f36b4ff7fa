"""Checkpoints: the whole SimState and the run's progress, in a file of their own
beside the output file (`run.h5md` → `run.h5md.checkpoint`), replaced atomically.

Why a file of its own, replaced whole: a checkpoint overwritten in place inside the
output file is lost when the process dies while writing it (kill -9, power cut,
full disk), and with it every step checkpointed so far.  Two slots inside the
output file would keep the old state's bytes, but not the HDF5 metadata that leads
to them: a kill in the middle of an HDF5 flush can leave the file's group B-trees,
heaps or superblock inconsistent, and a full disk leaves HDF5 unable to flush or
close the file at all (see `jaxdpd.io.h5md`).  A separate file that is complete
before it gets its name depends on none of that:

1. the output file is flushed and fsynced, so every sample the checkpoint counts
   is on disk (`jaxdpd.io.h5md.H5MDWriter.write_checkpoint`);
2. the checkpoint is built in memory as an HDF5 image (h5py's core driver), so HDF5
   never writes to disk and a full disk cannot leave it in a broken state;
3. the image is written to `<checkpoint>.tmp` with plain `os.write`, fsynced, and
   renamed over `<checkpoint>` (`os.replace`, atomic on POSIX file systems); the
   directory is fsynced so that the rename survives a power cut.

A kill at any moment leaves the previous checkpoint or the new one, whole; a full
disk fails step 3 with OSError before the rename and leaves the previous one.

Measured (benchmarks/checkpoint_survival.py: a writer checkpointing three (3000, 3)
arrays after every chunk, killed with SIGKILL at a random instant, 100 kills per
design): the checkpoint overwritten in place was lost 50 times, two slots inside the
output file and this design never.  (An earlier run of 30 kills each: 9, 0 and 0, and
once, with two slots, the output file itself was left with an unreadable last block:
a kill inside HDF5's flush of the series, which no checkpoint design prevents; a
restart refuses such a file with a named error unless the damage lies past the
checkpoint and is cut away.)  Two slots survive kills as well, but not a full disk:
after a failed write HDF5 can neither flush nor close the file (jaxdpd.io.h5md), so
the slot being written and the pointer to it cannot be completed, and a slot whose
shapes change (a reallocated neighbour list) rewrites the file's metadata.  One write
took 3.1 ms in place, 4.2 ms with two slots and 6.8 ms here (three fsyncs); the
demo's full state, 10.6 MiB, about 75 ms (benchmarks/checkpoint_cost.py).

Layout of a checkpoint file:

    /                    attrs: header (JSON), header_crc32 (CRC-32 of the header)
     +-- state/          every SimState leaf, each with its CRC-32
     |                   (jaxdpd.io.pytree_store)
     \\-- extras/         host-side accumulators (e.g. the g(r) histogram), likewise

    header = {"format": FORMAT, "step", "time", "phase", "reason", "run_id",
              "scene": Scene.to_dict(), "series": {element path: samples}}

`phase` is "equilibration" or "production" (see jaxdpd.run.runner); `reason` says why
it was written ("end of run", "interrupted by SIGINT", "periodic", or the error that
stopped the run); `run_id` is that of the output file (`/parameters:run_id`), so a
checkpoint is never paired with another run's file; `series` holds the number of
samples every time series of the output file had when the checkpoint was written:
a restart truncates each to that length and refuses a file in which one is
missing or shorter.
"""

import contextlib
import json
import os
import zlib
from dataclasses import dataclass, field
from pathlib import Path

import h5py
import numpy as np

from jaxdpd.io.errors import RunFileError, open_run_file
from jaxdpd.io.pytree_store import read_leaf, read_tree, stored_leaf_names, write_tree

FORMAT = "jaxdpd checkpoint 1"
SUFFIX = ".checkpoint"
EQUILIBRATION = "equilibration"
PRODUCTION = "production"
PHASES = (EQUILIBRATION, PRODUCTION)
_HEADER_KEYS = ("format", "step", "time", "phase", "reason", "run_id", "scene", "series")


def checkpoint_path(run_path) -> Path:
    """The checkpoint file of the output file `run_path` (`run.h5md.checkpoint`)."""
    return Path(f"{run_path}{SUFFIX}")


@dataclass(frozen=True)
class CheckpointInfo:
    """What a checkpoint says about the run, without the state.

    Attributes:
        step: step counter of the stored state.
        time: simulated time of the stored state.
        phase: "equilibration" or "production".
        reason: why it was written.
        run_id: identifier of the output file it belongs to.
        scene: Scene.to_dict() of the run.
        series: element path (e.g. "observables/temperature") -> number of samples
            the output file held when the checkpoint was written.
        path: the checkpoint file.
        extras: name -> NumPy array of the host-side accumulators.
    """

    step: int
    time: float
    phase: str
    reason: str
    run_id: str
    scene: dict
    series: dict
    path: str
    extras: dict = field(default_factory=dict)


def write_checkpoint(
    path, state, phase: str, reason: str, run_id: str, scene: dict, series: dict, extras=None
) -> None:
    """Write `state` and the run's progress as the checkpoint file `path`, atomically.

    Args:
        path: the checkpoint file (see `checkpoint_path`).
        state: the SimState (any pytree of arrays with `step` and `time` leaves).
        phase: "equilibration" or "production".
        reason: why it is written.
        run_id: the output file's identifier.
        scene: Scene.to_dict() of the run.
        series: element path -> samples stored in the output file so far.
        extras: name -> array of host-side accumulators to store beside the state.
    Raises:
        OSError: the file could not be written (the previous checkpoint is intact).
    """
    if phase not in PHASES:
        raise ValueError(f"phase = {phase!r}; valid: {list(PHASES)}")
    header = {
        "format": FORMAT,
        "step": int(state.step),
        "time": float(state.time),
        "phase": phase,
        "reason": reason,
        "run_id": run_id,
        "scene": scene,
        "series": {name: int(n) for name, n in series.items()},
    }
    text = json.dumps(header, sort_keys=True)
    # An in-memory HDF5 file (no backing store): HDF5 itself never touches the disk.
    with h5py.File(f"{path}.image", "w", driver="core", backing_store=False) as image:
        image.attrs["header"] = text
        image.attrs["header_crc32"] = np.uint32(zlib.crc32(text.encode()))
        write_tree(image.create_group("state"), state)
        extras = {name: np.asarray(value) for name, value in (extras or {}).items()}
        write_tree(image.create_group("extras"), extras)
        image.flush()
        data = image.id.get_file_image()
    _replace_atomically(Path(path), data)


def _replace_atomically(path: Path, data: bytes) -> None:
    """Write `data` to `path` such that `path` holds its old content or all of the
    new, whatever happens: temporary file, fsync, rename, fsync of the directory."""
    temporary = path.with_name(path.name + ".tmp")
    try:
        descriptor = os.open(temporary, os.O_WRONLY | os.O_CREAT | os.O_TRUNC, 0o644)
        try:
            view = memoryview(data)
            while view:
                view = view[os.write(descriptor, view) :]
            os.fsync(descriptor)
        finally:
            os.close(descriptor)
        os.replace(temporary, path)
    except BaseException:
        temporary.unlink(missing_ok=True)
        raise
    # The rename is done: a file system that cannot fsync a directory (some network
    # file systems, Windows) only loses the guarantee against a power cut.
    with contextlib.suppress(OSError):
        directory = os.open(path.parent, os.O_RDONLY)
        try:
            os.fsync(directory)
        finally:
            os.close(directory)


def _header(handle) -> dict:
    """The checkpoint's header, its checksum and keys verified."""
    name = handle.filename
    try:
        text, expected = handle.attrs["header"], handle.attrs["header_crc32"]
    except KeyError:
        raise RunFileError(f"{name}: not a jaxdpd checkpoint (no header)") from None
    if zlib.crc32(str(text).encode()) != int(expected):
        raise RunFileError(f"{name}: the checkpoint header fails its checksum (corrupted)")
    header = json.loads(text)
    if header.get("format") != FORMAT or set(header) != set(_HEADER_KEYS):
        raise RunFileError(
            f"{name}: a checkpoint of format {header.get('format')!r}, not {FORMAT!r} "
            "(written by another version of jaxdpd?)"
        )
    if header["phase"] not in PHASES:
        raise RunFileError(f"{name}: checkpoint phase {header['phase']!r} is not one of {PHASES}")
    return header


def _open(run_path):
    """The checkpoint file of `run_path` opened for reading, or RunFileError saying
    why there is none."""
    path = checkpoint_path(run_path)
    if not path.exists():
        raise RunFileError(
            f"{run_path}: has no checkpoint ({path} does not exist: the run was stopped "
            "before writing one, see output.checkpoint_every and checkpoint_seconds)"
        )
    return open_run_file(path)


def read_checkpoint_info(run_path) -> CheckpointInfo:
    """The checkpoint's header and extras (no state), all checksums verified."""
    with _open(run_path) as handle:
        header = _header(handle)
        extras_group = handle["extras"]
        extras = {name: read_leaf(extras_group, name) for name in stored_leaf_names(extras_group)}
    fields = {key: header[key] for key in _HEADER_KEYS[1:]}
    return CheckpointInfo(**fields, path=str(checkpoint_path(run_path)), extras=extras)


def read_checkpoint_state(run_path, template):
    """The checkpointed SimState, restored into the structure of `template`
    (the initial state of the file's scene); every leaf bit-identical."""
    with _open(run_path) as handle:
        step = _header(handle)["step"]
        state = read_tree(handle["state"], template)
        if int(state.step) != step:
            raise RunFileError(
                f"{handle.filename}: the state is at step {int(state.step)}, the header "
                f"says {step} (corrupted)"
            )
    return state


def read_checkpoint_leaves(run_path) -> dict:
    """{leaf path: NumPy array} of the checkpointed state, without a template."""
    with _open(run_path) as handle:
        _header(handle)
        state = handle["state"]
        return {name: read_leaf(state, name) for name in stored_leaf_names(state)}
