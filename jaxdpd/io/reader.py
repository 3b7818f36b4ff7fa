"""Reading jaxdpd H5MD files back: the scene, the checkpointed state, the series.

Every failure to read (missing or truncated file, damaged content, an invalid stored
scene, a checkpoint that does not fit the scene) raises `RunFileError` naming the
file and the part, never a bare h5py or JAX exception.
"""

import contextlib
import json
from dataclasses import dataclass
from typing import NamedTuple

import h5py
import numpy as np

from jaxdpd.io import checkpoint
from jaxdpd.io.errors import RunFileError
from jaxdpd.io.layout import PARTICLES


class Series(NamedTuple):
    """A time-dependent element: step (T,) int64, time (T,) float64, value (T, ...)."""

    step: np.ndarray
    time: np.ndarray
    value: np.ndarray


@dataclass
class RunRecord:
    """A file loaded back.

    Attributes:
        scene: the Scene the run was made from.
        state: the checkpointed SimState (None when the file holds no checkpoint).
        checkpoint: the checkpoint's step, phase and reason (None without one).
        observables: name -> Series of every stored observable.
    """

    scene: object
    state: object
    checkpoint: checkpoint.CheckpointInfo | None
    observables: dict


@contextlib.contextmanager
def open_run_file(path, mode: str = "r"):
    """Open a file, turning every h5py failure inside the block into RunFileError."""
    try:
        handle = h5py.File(str(path), mode)
    except FileNotFoundError:
        raise RunFileError(f"{path}: no such file") from None
    except OSError as error:
        raise RunFileError(f"{path}: not a readable HDF5 file ({_first_line(error)})") from None
    try:
        yield handle
    except (OSError, KeyError, RuntimeError) as error:
        raise RunFileError(f"{path}: damaged or incomplete ({_first_line(error)})") from None
    finally:
        with contextlib.suppress(Exception):
            handle.close()


def _first_line(error) -> str:
    return str(error).strip().splitlines()[0] if str(error).strip() else type(error).__name__


def scene_of(handle):
    """The Scene stored in an open file (validated again)."""
    from jaxdpd.scene import Scene

    name = handle.filename
    if "parameters" not in handle or "scene" not in handle["parameters"].attrs:
        raise RunFileError(f"{name}: not a jaxdpd file (no /parameters:scene attribute)")
    text = handle["parameters"].attrs["scene"]
    try:
        data = json.loads(text)
    except (TypeError, ValueError) as error:
        raise RunFileError(f"{name}: the stored scene is not valid JSON ({error})") from None
    try:
        return Scene.from_dict(data)
    except (TypeError, ValueError) as error:
        raise RunFileError(f"{name}: the stored scene is invalid ({error})") from None


def read_scene(path):
    """The Scene stored in a jaxdpd H5MD file."""
    with open_run_file(path) as handle:
        return scene_of(handle)


def read_state(path, simulation=None):
    """The checkpointed SimState of a file.

    Args:
        path: the file.
        simulation: the built simulation of the file's scene (built here when None);
            its initial state is the template the leaves are restored into.
    Returns:
        The SimState, every leaf with the stored dtype, shape and bits.
    """
    from jaxdpd.simulation import build

    with open_run_file(path) as handle:
        simulation = simulation if simulation is not None else build(scene_of(handle))
        checkpoint.read_checkpoint_info(handle)  # refuses missing or incomplete ones
        return checkpoint.read_checkpoint_state(handle, simulation.init_fn())


def read_checkpoint(path) -> dict:
    """The checkpoint as plain data: step, time, phase, reason and every state leaf by
    its path ("positions", "pair_list/i", ...), as NumPy arrays; no scene needed."""
    with open_run_file(path) as handle:
        info = checkpoint.read_checkpoint_info(handle)
        data = checkpoint.read_checkpoint_leaves(handle)
        data.update(
            step=info.step,
            time=float(handle[checkpoint.GROUP].attrs["time"]),
            phase=info.phase,
            reason=info.reason,
        )
        return data


def _series(group) -> Series:
    return Series(group["step"][()], group["time"][()], group["value"][()])


def time_series_names(handle) -> list[str]:
    """Names of the per-step series stored in an open file ("temperature",
    "A/end_to_end_sq", "pressure_tensor_part/bond"), in the order they were created."""

    def names_in(group, prefix=""):
        for name, item in group.items():
            if isinstance(item, h5py.Group):
                if "value" in item and "step" in item:
                    yield prefix + name
                else:
                    yield from names_in(item, f"{prefix}{name}/")

    return list(names_in(handle["observables"])) if "observables" in handle else []


def _read_element(path, element: str, hint) -> Series:
    """The time-dependent element at `element`, or RunFileError with `hint(handle)`."""
    with open_run_file(path) as handle:
        if element not in handle:
            raise RunFileError(f"{path}: no {element} ({hint(handle)})")
        return _series(handle[element])


def read_observable(path, name: str) -> Series:
    """One stored observable as NumPy arrays (step, time, value)."""
    return _read_element(
        path, f"observables/{name}", lambda handle: f"stored: {time_series_names(handle)}"
    )


def read_observables(path) -> dict:
    """Every stored observable: name -> Series."""
    with open_run_file(path) as handle:
        return {name: _series(handle[f"observables/{name}"]) for name in time_series_names(handle)}


def read_trajectory(path, element: str = "position") -> Series:
    """Stored frames of "position", "velocity" or "image": value (T, N, 3)."""
    return _read_element(
        path, f"{PARTICLES}/{element}", lambda _: "set output.trajectory_every to write frames"
    )


def read_unwrapped_positions(path) -> Series:
    """Stored frames unwrapped: r + n · edges, value (T, N, 3) float64.

    The rule for every file (and any H5MD reader): add to each position its image
    counters times the frame's box edges, n_x a1 + n_y a2 + n_z a3, the rows of a
    (3, 3) `edges` or the diagonal of a (3,) one.  For a Lees–Edwards box a2 =
    (Δ, L_y, 0) holds the frame's offset; the counters are carried across the
    offset's wraps (jaxdpd.boxes.lees_edwards), so the unwrapped trajectory is
    continuous, the laboratory-frame path of each particle.  Kraynik–Reinelt frames
    have no such rule (the lattice basis changes at each reset): RunFileError.
    """
    with open_run_file(path) as handle:
        if scene_of(handle).box.kind == "kraynik_reinelt":
            raise RunFileError(
                f"{path}: Kraynik–Reinelt frames cannot be unwrapped (the lattice basis "
                "changes at each reset; image counters count faces of the current cell)"
            )
        particles = f"{PARTICLES}/position"
        if particles not in handle:
            raise RunFileError(f"{path}: no {particles} (set output.trajectory_every)")
        position = _series(handle[particles])
        image = handle[f"{PARTICLES}/image/value"][()].astype(np.float64)
        edges = handle[f"{PARTICLES}/box/edges/value"][()]
    lattice = edges if edges.ndim == 3 else edges[:, :, None] * np.eye(3)
    unwrapped = position.value.astype(np.float64) + np.einsum("tni,tij->tnj", image, lattice)
    return Series(position.step, position.time, unwrapped)


def load(path) -> RunRecord:
    """Scene, checkpointed state (restored through the scene's build()) and every
    observable of a file."""
    from jaxdpd.simulation import build

    with open_run_file(path) as handle:
        scene = scene_of(handle)
        state = info = None
        if checkpoint.GROUP in handle:
            info = checkpoint.read_checkpoint_info(handle)
            state = checkpoint.read_checkpoint_state(handle, build(scene).init_fn())
        observables = {
            name: _series(handle[f"observables/{name}"]) for name in time_series_names(handle)
        }
    return RunRecord(scene, state, info, observables)
