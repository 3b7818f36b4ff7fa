"""Reading jaxdpd H5MD files back: the scene, the checkpointed state, the series.

Every failure to read (missing or truncated file, damaged content, an invalid stored
scene, a checkpoint that does not fit the scene) raises `RunFileError` naming the
file and the part, never a bare h5py or JAX exception.  The state is read from the
file's checkpoint file (`<file>.checkpoint`, jaxdpd.io.checkpoint).

Reading never builds or compiles a simulation (io does not import the engine): the
scene and the series come back as plain data, and the checkpointed state is restored
into a template state the caller built (jaxdpd.run.restore builds the stored scene
and restores its state in one call).
"""

import json
import zlib
from dataclasses import dataclass, field
from typing import NamedTuple

import h5py
import numpy as np

from jaxdpd.io import checkpoint
from jaxdpd.io.errors import RunFileError, open_run_file
from jaxdpd.io.layout import particle_group


class Series(NamedTuple):
    """A time-dependent element: step (T,) int64, time (T,) float64, value (T, ...)."""

    step: np.ndarray
    time: np.ndarray
    value: np.ndarray


class Correlation(NamedTuple):
    """A time correlation measured over a production run (/averages/<species>/<name>,
    e.g. the MSDs g1, g2, g3): lag_time (L,) in τ, value (L,) averaged over the
    chains (and beads), per_element (L, C[, M]) as measured, NaN at lags not reached."""

    lag_time: np.ndarray
    value: np.ndarray
    per_element: np.ndarray


class RadialDistribution(NamedTuple):
    """g(r) averaged over a production run (/averages/rdf): bin centres r (K,) in r_c,
    g (K,), and the number of frames sampled."""

    r: np.ndarray
    g: np.ndarray
    samples: int


@dataclass
class RunRecord:
    """A file loaded back.

    Attributes:
        scene: the Scene the run was made from.
        checkpoint: the checkpoint's step, phase and reason (None without one); its
            state is read by `read_state` (or jaxdpd.run.restore).
        observables: name -> Series of every stored observable.
        averages: what the run measured over its whole production (`read_averages`):
            "rdf" -> RadialDistribution, "<species>/<name>" -> Correlation.
    """

    scene: object
    checkpoint: checkpoint.CheckpointInfo | None
    observables: dict
    averages: dict = field(default_factory=dict)


def scene_of(handle):
    """The Scene stored in an open file (validated again)."""
    from jaxdpd.scene import Scene

    name = handle.filename
    if "parameters" not in handle or "scene" not in handle["parameters"].attrs:
        raise RunFileError(f"{name}: not a jaxdpd file (no /parameters:scene attribute)")
    text = handle["parameters"].attrs["scene"]
    expected = handle["parameters"].attrs.get("scene_crc32")
    if expected is None:
        raise RunFileError(
            f"{name}: /parameters has no scene_crc32 (written by a jaxdpd older than its "
            "checksummed scenes, or edited)"
        )
    if zlib.crc32(str(text).encode()) != int(expected):
        raise RunFileError(
            f"{name}: the stored scene (/parameters:scene) fails its checksum (the file "
            "was damaged or edited); it is not run"
        )
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


def read_state(path, template):
    """The checkpointed SimState of a file, restored into the structure of `template`.

    Args:
        path: the file.
        template: a state of the file's scene (e.g. `build(read_scene(path)).init_fn()`;
            jaxdpd.run.restore does this); it gives the pytree structure and the static
            parts, the file every leaf.
    Returns:
        The SimState, every leaf with the stored dtype, shape and bits.
    """
    return checkpoint.read_checkpoint_state(path, template)


def read_checkpoint(path) -> dict:
    """The checkpoint as plain data: step, time, phase, reason and every state leaf by
    its path ("positions", "pair_list/i", ...), as NumPy arrays; no scene needed."""
    info = checkpoint.read_checkpoint_info(path)
    data = checkpoint.read_checkpoint_leaves(path)
    data.update(step=info.step, time=info.time, phase=info.phase, reason=info.reason)
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
    """The time-dependent element at `element` ("particles/" standing for the
    file's particle group), or RunFileError with `hint(handle)`."""
    with open_run_file(path) as handle:
        if element.startswith("particles/"):
            element = element.replace("particles", particle_group(handle), 1)
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
        path, f"particles/{element}", lambda _: "set output.trajectory_every to write frames"
    )


def read_unwrapped_positions(path) -> Series:
    """Stored frames unwrapped: r + n · edges, value (T, N, 3) float64.

    The rule for every file (and any H5MD reader): add to each position its image
    counters times the frame's box edges, n_x a1 + n_y a2 + n_z a3, the rows of a
    (3, 3) `edges` or the diagonal of a (3,) one.  For a Lees–Edwards box a2 =
    (Δ, L_y, 0) holds the frame's offset; the counters are carried across the
    offset's wraps (jaxdpd.geometry.boxes.lees_edwards), so the unwrapped trajectory is
    continuous, the laboratory-frame path of each particle.  Kraynik–Reinelt frames
    have no such rule (the lattice basis changes at each reset): RunFileError.
    """
    with open_run_file(path) as handle:
        if scene_of(handle).box.kind == "kraynik_reinelt":
            raise RunFileError(
                f"{path}: Kraynik–Reinelt frames cannot be unwrapped (the lattice basis "
                "changes at each reset; image counters count faces of the current cell)"
            )
        particles = particle_group(handle)
        if f"{particles}/position" not in handle:
            raise RunFileError(f"{path}: no {particles}/position (set output.trajectory_every)")
        position = _series(handle[f"{particles}/position"])
        image = handle[f"{particles}/image/value"][()].astype(np.float64)
        edges = handle[f"{particles}/box/edges/value"][()]
    lattice = edges if edges.ndim == 3 else edges[:, :, None] * np.eye(3)
    unwrapped = position.value.astype(np.float64) + np.einsum("tni,tij->tnj", image, lattice)
    return Series(position.step, position.time, unwrapped)


def averages_of(handle) -> dict:
    """Everything under /averages of an open file (see `read_averages`)."""
    if "averages" not in handle:
        return {}
    found = {}

    def visit(name, item):
        if not isinstance(item, h5py.Group):
            return
        if "lag_time" in item:
            found[name] = Correlation(
                item["lag_time"][()], item["value"][()], item["per_element"][()]
            )
        elif "g" in item and "r" in item:
            found[name] = RadialDistribution(
                item["r"][()], item["g"][()], int(item.attrs.get("samples", 0))
            )

    handle["averages"].visititems(visit)
    return found


def read_averages(path) -> dict:
    """What a run measured over its whole production, written at its end: "rdf" ->
    RadialDistribution (scenes observing "rdf"), "<species>/<g1|g2|g3|...>" ->
    Correlation (the on-device chain correlators of "dynamics"); {} when none."""
    with open_run_file(path) as handle:
        return averages_of(handle)


def load(path) -> RunRecord:
    """Scene, checkpoint header (None when the file has no checkpoint file), every
    observable and every average of a file; nothing is built or compiled."""
    with open_run_file(path) as handle:
        scene = scene_of(handle)
        run_id = handle["parameters"].attrs.get("run_id")
        observables = {
            name: _series(handle[f"observables/{name}"]) for name in time_series_names(handle)
        }
        averages = averages_of(handle)
    info = None
    if checkpoint.checkpoint_path(path).exists():
        info = checkpoint.read_checkpoint_info(path)
        if info.run_id != run_id:
            raise RunFileError(
                f"{checkpoint.checkpoint_path(path)}: belongs to another run than {path}"
            )
    return RunRecord(scene, info, observables, averages)
