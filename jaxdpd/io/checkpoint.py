"""Checkpoints: the whole SimState and the run's progress, inside the output file.

Layout (a group the H5MD specification leaves to applications):

    /checkpoint
     +-- step, time          the state's step counter and simulated time
     +-- phase               "equilibration" or "production": the part of the run
                             the state belongs to (see jaxdpd.runner)
     +-- reason              why it was written ("end of run", "interrupted by
                             SIGINT", "periodic", or the error that stopped the run)
     +-- complete            False while it is being written: a run killed in the
                             middle leaves a checkpoint the reader refuses
     \\-- state/              every SimState leaf (jaxdpd.io.pytree_store)
     \\-- extras/<name>       host-side accumulators (e.g. the g(r) histogram)

A checkpoint is overwritten in place by the next one (same shapes), so periodic
checkpoints do not grow the file.
"""

from dataclasses import dataclass, field

import numpy as np

from jaxdpd.io.errors import RunFileError
from jaxdpd.io.pytree_store import read_leaf, read_tree, stored_leaf_names, write_tree

GROUP = "checkpoint"
EQUILIBRATION = "equilibration"
PRODUCTION = "production"
PHASES = (EQUILIBRATION, PRODUCTION)


@dataclass(frozen=True)
class CheckpointInfo:
    """What a checkpoint says about the run, without the state.

    Attributes:
        step: step counter of the stored state.
        phase: "equilibration" or "production".
        reason: why it was written.
        extras: name -> NumPy array of the host-side accumulators.
    """

    step: int
    phase: str
    reason: str
    extras: dict = field(default_factory=dict)


def write_checkpoint(handle, state, phase: str, reason: str, extras=None) -> None:
    """Store `state` and the run's progress as the file's checkpoint (replacing any).

    Args:
        handle: the open, writable h5py File.
        state: the SimState (any pytree of arrays with `step` and `time` leaves).
        phase: "equilibration" or "production".
        reason: why it is written (kept as an attribute).
        extras: name -> array of host-side accumulators to store beside the state.
    """
    if phase not in PHASES:
        raise ValueError(f"phase = {phase!r}; valid: {list(PHASES)}")
    group = handle.require_group(GROUP)
    group.attrs["complete"] = False
    write_tree(group.require_group("state"), state)
    extras = {name: np.asarray(value) for name, value in (extras or {}).items()}
    write_tree(group.require_group("extras"), extras)
    group.attrs["step"] = int(state.step)
    group.attrs["time"] = float(state.time)
    group.attrs["phase"] = phase
    group.attrs["reason"] = reason
    group.attrs["complete"] = True


def _group(handle):
    """The complete checkpoint group, or a RunFileError saying why there is none."""
    name = handle.filename
    if GROUP not in handle:
        raise RunFileError(
            f"{name}: holds no checkpoint (the run was killed before writing one; set "
            "output.checkpoint_every to write them periodically)"
        )
    group = handle[GROUP]
    if not group.attrs.get("complete", False):
        raise RunFileError(
            f"{name}: the checkpoint is incomplete (the run was killed while writing it)"
        )
    return group


def read_checkpoint_info(handle) -> CheckpointInfo:
    """The checkpoint's step, phase, reason and extras (no state)."""
    group = _group(handle)
    try:
        step, phase, reason = (group.attrs[k] for k in ("step", "phase", "reason"))
    except KeyError as error:
        raise RunFileError(f"{handle.filename}: checkpoint attribute {error} is missing") from None
    if phase not in PHASES:
        raise RunFileError(f"{handle.filename}: checkpoint phase {phase!r} is not one of {PHASES}")
    extras_group = group["extras"] if "extras" in group else {}
    extras = {name: read_leaf(extras_group, name) for name in extras_group}
    return CheckpointInfo(int(step), str(phase), str(reason), extras)


def read_checkpoint_state(handle, template):
    """The checkpointed SimState, restored into the structure of `template`
    (the initial state of the file's scene); every leaf bit-identical."""
    state = read_tree(_group(handle)["state"], template)
    if int(state.step) != int(handle[GROUP].attrs["step"]):
        raise RunFileError(
            f"{handle.filename}: checkpoint state is at step {int(state.step)}, its "
            f"attributes say {int(handle[GROUP].attrs['step'])} (corrupted)"
        )
    return state


def read_checkpoint_leaves(handle) -> dict:
    """{leaf path: NumPy array} of the checkpointed state, without a template."""
    state = _group(handle)["state"]
    return {name: read_leaf(state, name) for name in stored_leaf_names(state)}
