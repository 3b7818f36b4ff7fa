"""H5MD 1.1 output (de Buyl, Colberg and Höfling, Comput. Phys. Commun. 185, 1546 (2014)).

Layout written:
    /h5md                      version = [1, 1]; author, creator
    /parameters                attrs: scene (JSON of Scene.to_dict), units
    /particles/all/box         dimension = 3, boundary = periodic ×3, edges (3,)
    /particles/all/species     (N,) int32
    /particles/all/{position,velocity,image}/{step,time,value}   (every
                               output.trajectory_every steps)
    /observables/<name>/{step,time,value}   per-step time series
    /observables/rdf/{r,g}     radial distribution (fixed, rewritten at the end)
    /observables/<species>/<g1|g2|g3|end_to_end_acf>/{lag_time,value,per_element}
                               on-device time correlations (written at the end)
    /checkpoint                the full state of the last good step (restart)

Data is flushed after every chunk, so an interrupted run leaves a readable file.
"""

import json

import h5py
import numpy as np

import jaxdpd

UNITS = "reduced DPD units: r_c = m = k_BT = 1 (length r_c, time r_c sqrt(m/k_BT))"
CHECKPOINT_FIELDS = ("positions", "velocities", "forces", "image", "species")
CHECKPOINT_SCALARS = ("step", "time", "seed", "flags")


class H5MDWriter:
    """Streams a run into an H5MD file.

    Args:
        path: file to create (overwritten).
        scene: the Scene (stored in full as JSON).
    """

    def __init__(self, path, scene):
        self.path = str(path)
        self.scene = scene
        self.file = h5py.File(self.path, "w")
        h5md = self.file.create_group("h5md")
        h5md.attrs["version"] = np.array([1, 1], np.int32)
        h5md.create_group("author").attrs["name"] = "jaxdpd user"
        creator = h5md.create_group("creator")
        creator.attrs["name"] = "jaxdpd"
        creator.attrs["version"] = jaxdpd.__version__
        parameters = self.file.create_group("parameters")
        parameters.attrs["scene"] = scene.to_json()
        parameters.attrs["units"] = UNITS
        particles = self.file.create_group("particles/all")
        box = particles.create_group("box")
        box.attrs["dimension"] = 3
        box.attrs["boundary"] = np.array([b"periodic"] * 3)
        box.create_dataset("edges", data=np.asarray(scene.box.lengths, np.float64))
        particles.create_dataset(
            "species",
            data=np.repeat(
                np.arange(len(scene.particles.species), dtype=np.int32),
                [s.count for s in scene.particles.species],
            ),
        )
        self.file.create_group("observables")
        self.file.flush()

    def _time_series(self, group_path: str, sample_shape, dtype):
        """Create (or open) an H5MD time-dependent element with step, time, value."""
        if group_path in self.file:
            return self.file[group_path]
        group = self.file.create_group(group_path)
        group.create_dataset("step", (0,), np.int64, maxshape=(None,), chunks=(1024,))
        group.create_dataset("time", (0,), np.float64, maxshape=(None,), chunks=(1024,))
        chunk = (max(1, 2**16 // max(1, int(np.prod(sample_shape)))),) + tuple(sample_shape)
        group.create_dataset(
            "value",
            (0,) + tuple(sample_shape),
            dtype,
            maxshape=(None,) + tuple(sample_shape),
            chunks=chunk,
        )
        return group

    def _append(self, group_path: str, steps, times, values):
        values = np.asarray(values)
        group = self._time_series(group_path, values.shape[1:], values.dtype)
        start = group["step"].shape[0]
        for name, data in (("step", steps), ("time", times), ("value", values)):
            dataset = group[name]
            dataset.resize(start + len(values), axis=0)
            dataset[start:] = data

    def append_observables(self, first_step: int, dt: float, series: dict) -> None:
        """Append per-step series (each of length n) for steps first_step+1 … first_step+n."""
        for name, values in series.items():
            n = len(values)
            steps = np.arange(first_step + 1, first_step + n + 1, dtype=np.int64)
            self._append(f"observables/{name}", steps, steps * dt, values)

    def append_frame(self, state) -> None:
        """Append positions, velocities and image counters of `state`."""
        step = np.array([int(state.step)], np.int64)
        time = np.array([float(state.time)])
        for name, array in (
            ("position", state.positions),
            ("velocity", state.velocities),
            ("image", state.image),
        ):
            self._append(f"particles/all/{name}", step, time, np.asarray(array)[None])

    def write_rdf(self, r, g, samples: int) -> None:
        """(Re)write the radial distribution function."""
        if "observables/rdf" in self.file:
            del self.file["observables/rdf"]
        group = self.file.create_group("observables/rdf")
        group.create_dataset("r", data=r)
        group.create_dataset("g", data=g)
        group.attrs["samples"] = samples

    def write_correlation(self, name: str, lag_times, values) -> None:
        """(Re)write a time correlation: `observables/<name>/{lag_time,value}`, the
        value averaged over its chains (and beads), plus `per_element` (K, C[, M])."""
        path = f"observables/{name}"
        if path in self.file:
            del self.file[path]
        group = self.file.create_group(path)
        values = np.asarray(values)
        group.create_dataset("lag_time", data=np.asarray(lag_times, np.float64))
        group.create_dataset("value", data=values.reshape(len(values), -1).mean(axis=1))
        group.create_dataset("per_element", data=values)

    def write_checkpoint(self, state, reason: str = "") -> None:
        """Store the full state (replacing the previous checkpoint)."""
        if "checkpoint" in self.file:
            del self.file["checkpoint"]
        group = self.file.create_group("checkpoint")
        for name in CHECKPOINT_FIELDS:
            group.create_dataset(name, data=np.asarray(getattr(state, name)))
        virial = group.create_group("virial")
        for part, value in state.virial.items():
            virial.create_dataset(part, data=np.asarray(value))
        for name in CHECKPOINT_SCALARS:
            group.attrs[name] = np.asarray(getattr(state, name)).item()
        group.attrs["reason"] = reason
        self.flush()

    def flush(self) -> None:
        """Push everything written so far to disk."""
        self.file.flush()

    def close(self) -> None:
        """Flush and close (idempotent)."""
        if self.file.id.valid:
            self.file.flush()
            self.file.close()

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()


def read_scene(path):
    """The Scene stored in an H5MD file written by jaxdpd."""
    from jaxdpd.scene import Scene

    with h5py.File(path, "r") as handle:
        return Scene.from_dict(json.loads(handle["parameters"].attrs["scene"]))


def read_observable(path, name: str):
    """(step, time, value) NumPy arrays of a stored time series."""
    with h5py.File(path, "r") as handle:
        group = handle[f"observables/{name}"]
        return group["step"][()], group["time"][()], group["value"][()]


def read_checkpoint(path) -> dict:
    """The checkpoint group as a dict of NumPy arrays and scalars."""
    with h5py.File(path, "r") as handle:
        group = handle["checkpoint"]
        data = {name: group[name][()] for name in CHECKPOINT_FIELDS}
        data["virial"] = {part: value[()] for part, value in group["virial"].items()}
        data.update({name: group.attrs[name] for name in CHECKPOINT_SCALARS})
        data["reason"] = group.attrs["reason"]
        return data
