"""H5MD 1.1 output (de Buyl, Colberg and Höfling, Comput. Phys. Commun. 185, 1546 (2014);
specification at nongnu.org/h5md, version 1.1).

Layout written:

    /h5md                       version = [1, 1]; author/name; creator/name, version
    /parameters                 attrs: scene (JSON of Scene.to_dict), units
    /particles/all
         box                    dimension = 3, boundary = periodic ×3
              edges/{step,time,value (T, 3)}     sampled with the positions (T, 3, 3
                                                 lattice vectors in Lees–Edwards
                                                 shear and Kraynik–Reinelt planar
                                                 elongation, see box_edges), or the fixed
                                                 (3,) edge lengths without frames
         species                (N,) HDF5 enumeration: species index → name
         position/{step,time,value (T, N, 3)}    every output.trajectory_every
         velocity/{value (T, N, 3)}              production steps; step and time
         image/{value (T, N, 3) int32}           hard-linked to position's (spec)
    /connectivity/bonds         (B, 2) bonded pairs of the polymer chains
    /observables/<name>/{step,time,value}        per-step series of the production
                                attr warning: a failed sanity check of its mean
                                (temperature off the set k_BT)
    /averages/rdf/{r, g}        g(r) averaged over the run (time-independent)
    /averages/<species>/<g1|g2|g3|end_to_end_acf|positional_acf>/{lag_time,value,per_element}
                                on-device time correlations over the production
    /checkpoint                 the whole state (jaxdpd.io.checkpoint)

Times are step × scene.step_time (integrator.dt; the collision time h for MPCD).
Data carry no H5MD `unit` attribute: jaxdpd works in reduced units, which the H5MD
units module (SI only) cannot express; the unit of each element is given by a
`reduced_unit` attribute and the convention by /parameters:units.  MDAnalysis
therefore opens the files with `convert_units=False`.
g(r) and the time correlations sit under /averages rather than /observables because
MDAnalysis reads every observable at every frame index.  Time series are written with Fletcher-32
checksums, so corrupted data raise an error when read.

The file is flushed after every chunk: an interrupted run leaves a readable file.
"""

import getpass

import h5py
import numpy as np

import jaxdpd
from jaxdpd.io.checkpoint import write_checkpoint
from jaxdpd.io.errors import RunFileError
from jaxdpd.io.layout import CHUNK_BYTES, FRAME_ELEMENTS, PARTICLES, UNITS, reduced_unit

# Readers, importable from here as in earlier versions.
from jaxdpd.io.reader import read_checkpoint, read_observable, read_scene  # noqa: F401


def time_series_groups(handle) -> list:
    """Every time-dependent element (group with `step` and `value`) in the file."""
    found = []

    def visit(_, item):
        if isinstance(item, h5py.Group) and "step" in item and "value" in item:
            found.append(item)

    for root in ("particles", "observables"):
        if root in handle:
            handle[root].visititems(visit)
    return found


def box_edges(bound_box) -> np.ndarray:
    """The H5MD `edges` of a box at one instant (float64).

    A box at rest gives its edge lengths (3,) (H5MD "cuboid").  A Lees–Edwards box
    gives its lattice vectors as rows (3, 3), a1 = (L_x, 0, 0), a2 = (Δ, L_y, 0),
    a3 = (0, 0, L_z) with Δ its current offset (H5MD "triclinic"): the periodic
    images of a sheared system are exactly those of this lattice, so tools that read
    triclinic boxes (MDAnalysis) find the right minimum images.  A Kraynik–Reinelt
    box gives its current primary cell the same way, rows (frame axis 0, y, frame axis
    2) of jaxdpd.boxes.kraynik_reinelt, tilted in the x–z plane and centred on the
    stagnation point (tools that rotate a triclinic cell into a standard orientation
    lose that tilt).

    Args:
        bound_box: the simulation's box bound to a state's box_state.
    """
    lattice = getattr(bound_box, "lattice_vectors", None)
    if lattice is not None:
        return np.asarray(lattice, np.float64).T
    lengths = np.asarray(bound_box.lengths, np.float64)
    offset = getattr(bound_box, "offset", None)
    if offset is None:
        return lengths
    edges = np.diag(lengths)
    edges[1, 0] = float(offset)
    return edges


def bond_pairs(blocks) -> np.ndarray:
    """(B, 2) int32 particle index pairs of every spring of the chain blocks."""
    pairs = [np.zeros((0, 2), np.int32)]
    for block in blocks:
        beads = np.arange(block.first, block.stop, dtype=np.int32).reshape(block.n_chains, -1)
        pairs.append(np.stack([beads[:, :-1].ravel(), beads[:, 1:].ravel()], axis=1))
    return np.concatenate(pairs)


class H5MDWriter:
    """Streams a run into an H5MD file (use `create` or `reopen`).

    Args:
        handle: the open, writable h5py File.
        scene: the Scene being run.
    """

    def __init__(self, handle, scene):
        self.file = handle
        self.scene = scene
        self.path = handle.filename

    # -- opening ---------------------------------------------------------------------
    @classmethod
    def create(cls, path, scene, blocks=()) -> "H5MDWriter":
        """A new file (overwriting any) with the metadata, scene, species and bonds.

        Args:
            path: file to create.
            scene: the Scene.
            blocks: the scene's polymer ChainBlocks (their springs are stored).
        """
        try:
            handle = h5py.File(str(path), "w")
        except OSError as error:
            raise RunFileError(f"{path}: cannot create the output file ({error})") from None
        h5md = handle.create_group("h5md")
        h5md.attrs["version"] = np.array([1, 1], np.int32)
        h5md.create_group("author").attrs["name"] = _author()
        creator = h5md.create_group("creator")
        creator.attrs["name"] = "jaxdpd"
        creator.attrs["version"] = jaxdpd.__version__
        writer = cls(handle, scene)
        writer._write_scene()
        particles = handle.create_group(PARTICLES)
        box = particles.create_group("box")
        box.attrs["dimension"] = 3
        box.attrs["boundary"] = np.array([b"periodic"] * 3)
        if not scene.output.trajectory_every:  # else sampled with the frames
            box.create_dataset("edges", data=np.asarray(scene.box.lengths, np.float64))
        names = scene.species_names
        species_type = h5py.enum_dtype({n: k for k, n in enumerate(names)}, basetype="i4")
        particles.create_dataset(
            "species",
            data=np.repeat(np.arange(len(names)), [s.count for s in scene.particles.species]),
            dtype=species_type,
        )
        if blocks:
            bonds = handle.create_dataset("connectivity/bonds", data=bond_pairs(blocks))
            bonds.attrs["particles_group"] = particles.ref
        handle.create_group("observables", track_order=True)  # series in the run's order
        handle.flush()
        return writer

    @classmethod
    def reopen(cls, path, scene, after_step: int) -> "H5MDWriter":
        """An existing jaxdpd file, to continue a run from its checkpoint.

        Samples past `after_step` (written after the checkpoint by a run that was then
        killed) are dropped, so the continued run appends without duplicates; the
        scene attribute is replaced by `scene` (e.g. with more run.steps).
        """
        try:
            handle = h5py.File(str(path), "r+")
        except OSError as error:
            raise RunFileError(f"{path}: cannot be opened for appending ({error})") from None
        writer = cls(handle, scene)
        for group in time_series_groups(handle):
            keep = _samples_up_to(group["step"], after_step)
            for name in ("step", "time", "value"):
                if name in group and group[name].shape[0] > keep:
                    group[name].resize(keep, axis=0)
        writer._write_scene()
        handle.flush()
        return writer

    def _write_scene(self) -> None:
        parameters = self.file.require_group("parameters")
        parameters.attrs["scene"] = self.scene.to_json()
        parameters.attrs["units"] = UNITS

    # -- time series -----------------------------------------------------------------
    def _series(self, path: str, sample_shape, dtype, clock=None):
        """Open or create a time-dependent element; `clock` is another element whose
        step and time datasets are hard-linked (sampled at the same steps)."""
        if path in self.file:
            return self.file[path]
        group = self.file.create_group(path)
        if clock is None:
            for name, kind in (("step", np.int64), ("time", np.float64)):
                group.create_dataset(
                    name, (0,), kind, maxshape=(None,), chunks=(CHUNK_BYTES // 8,), fletcher32=True
                )
            group["time"].attrs["reduced_unit"] = reduced_unit("time")
        else:
            group["step"], group["time"] = clock["step"], clock["time"]
        sample_shape = tuple(sample_shape)
        sample_bytes = max(1, int(np.prod(sample_shape)) * np.dtype(dtype).itemsize)
        value = group.create_dataset(
            "value",
            (0, *sample_shape),
            dtype,
            maxshape=(None, *sample_shape),
            chunks=(max(1, CHUNK_BYTES // sample_bytes), *sample_shape),
            fletcher32=True,
        )
        unit = reduced_unit(path)
        if unit:
            value.attrs["reduced_unit"] = unit
        return group

    @staticmethod
    def _extend(dataset, rows) -> None:
        start = dataset.shape[0]
        dataset.resize(start + len(rows), axis=0)
        dataset[start:] = rows

    def append_observables(self, first_step: int, series: dict) -> None:
        """Append per-step series (each of length n) for steps first_step+1 … first_step+n."""
        dt = self.scene.step_time
        for name, values in series.items():
            values = np.asarray(values)
            steps = np.arange(first_step + 1, first_step + len(values) + 1, dtype=np.int64)
            group = self._series(f"observables/{name}", values.shape[1:], values.dtype)
            for dataset, rows in (("step", steps), ("time", steps * dt), ("value", values)):
                self._extend(group[dataset], rows)

    def append_frame(self, state, edges) -> None:
        """Append positions, velocities, image counters and box edges of `state`."""
        step = int(state.step)
        position = None
        for name in FRAME_ELEMENTS:
            value = np.asarray(getattr(state, _STATE_FIELD[name]))
            group = self._series(f"{PARTICLES}/{name}", value.shape, value.dtype, position)
            if position is None:
                position = group
                self._extend(group["step"], [step])
                self._extend(group["time"], [step * self.scene.step_time])
            self._extend(group["value"], value[None])
        edges = np.asarray(edges, np.float64)
        box_edges = self._series(f"{PARTICLES}/box/edges", edges.shape, edges.dtype, position)
        self._extend(box_edges["value"], edges[None])

    # -- run results -----------------------------------------------------------------
    def write_rdf(self, r, g, samples: int) -> None:
        """(Re)write the radial distribution function averaged over `samples` frames."""
        if "averages/rdf" in self.file:
            del self.file["averages/rdf"]
        group = self.file.create_group("averages/rdf")
        group.create_dataset("r", data=r).attrs["reduced_unit"] = "r_c"
        group.create_dataset("g", data=g)
        group.attrs["samples"] = samples

    def write_warning(self, name: str, message: str | None) -> None:
        """Set (or, with None, remove) the `warning` attribute of observables/<name>: a
        sanity check of the run's averages that failed (jaxdpd.temperature_check)."""
        attributes = self.file[f"observables/{name}"].attrs
        if message is not None:
            attributes["warning"] = message
        elif "warning" in attributes:
            del attributes["warning"]

    def write_correlation(self, name: str, lag_times, values) -> None:
        """(Re)write a time correlation measured over the run:
        `averages/<name>/{lag_time, value, per_element}`, the value averaged over its
        chains (and beads), per_element (K, C[, M]) as measured."""
        path = f"averages/{name}"
        if path in self.file:
            del self.file[path]
        group = self.file.create_group(path)
        values = np.asarray(values)
        group.create_dataset("lag_time", data=np.asarray(lag_times, np.float64))
        group["lag_time"].attrs["reduced_unit"] = reduced_unit("time")
        group.create_dataset("value", data=values.reshape(len(values), -1).mean(axis=1))
        group.create_dataset("per_element", data=values)

    def write_checkpoint(self, state, phase: str, reason: str, extras=None) -> None:
        """Store the whole state (jaxdpd.io.checkpoint) and flush."""
        write_checkpoint(self.file, state, phase, reason, extras)
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


def _samples_up_to(steps, last_step: int) -> int:
    """Number of entries ≤ last_step in an increasing step dataset (binary search on
    the file: a long series is not loaded)."""
    low, high = 0, steps.shape[0]
    while low < high:
        middle = (low + high) // 2
        if steps[middle] <= last_step:
            low = middle + 1
        else:
            high = middle
    return low


_STATE_FIELD = {"position": "positions", "velocity": "velocities", "image": "image"}


def _author() -> str:
    try:
        return getpass.getuser()
    except (KeyError, OSError):
        return "unknown"
