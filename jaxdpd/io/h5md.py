"""H5MD 1.1 output (de Buyl, Colberg and Höfling, Comput. Phys. Commun. 185, 1546 (2014);
specification at nongnu.org/h5md, version 1.1).

Layout written:

    /h5md                       version = [1, 1]; author/name (output.author, default
                                the OS login); creator/name, version
    /parameters                 attrs: scene (JSON of Scene.to_dict), scene_crc32
                                (its CRC-32: a damaged scene is refused, not run),
                                run_id (pairs the file with its checkpoints), units
    /particles/trajectory       (named so for MDAnalysis, see jaxdpd.io.layout; files
                                written before name it "all" and stay readable)
         box                    dimension = 3, boundary = periodic ×3
              edges/{step,time,value (T, 3)}     sampled with the positions (T, 3, 3
                                                 lattice vectors in Lees–Edwards
                                                 shear and Kraynik–Reinelt planar
                                                 elongation, see box_edges), or the fixed
                                                 (3,) edge lengths without frames
         species                (N,) HDF5 enumeration: species index → name
         mass                   (N,) particle masses (units of m; time-independent)
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

The whole state for restarts is in a checkpoint file beside this one,
`<file>.checkpoint` (jaxdpd.io.checkpoint), replaced atomically.

Times are step × scene.step_time (integrator.dt; the collision time h for MPCD).
Data carry no H5MD `unit` attribute: jaxdpd works in reduced units, which the H5MD
units module (SI only) cannot express; the unit of each dataset (values, times, lag
times; "1" for dimensionless ones) is given by a `reduced_unit` attribute and the
convention by /parameters:units.  MDAnalysis therefore opens the files with
`convert_units=False`.  New files end in `.h5md` where jaxdpd names them
(jaxdpd.io.layout.EXTENSION).
g(r) and the time correlations sit under /averages rather than /observables because
MDAnalysis reads every observable at every frame index.  Time series are written with Fletcher-32
checksums, so corrupted data raise an error when read.

The file is flushed after every chunk: an interrupted run leaves a readable file.

Write failures (a full disk, an I/O error) raise OutputError.  HDF5 cannot recover
from a failed write: every later flush of the file fails ("slist already enabled?")
and closing it crashes the process with a segmentation fault (HDF5 2.0.0, measured
on a full tmpfs).  So after the first failure the writer points the file's
descriptor at an anonymous file in memory and closes the file there (HDF5's closing
writes and its final ftruncate then succeed; /dev/null refuses the ftruncate and the
close fails): the process goes on (and exits) normally, and the file on disk stays
as it was when the write failed; a restart truncates it to its last checkpoint.
The file is opened without a chunk cache (`rdcc_nbytes=0`): every chunk is written
by the call that fills it, so a failure is raised there, not in the garbage
collection of a dataset (where h5py can only print it, and the crash follows).
"""

import contextlib
import getpass
import os
import tempfile
import uuid
import zlib

import h5py
import numpy as np

import jaxdpd
from jaxdpd.io import checkpoint
from jaxdpd.io.errors import OutputError, RunFileError, first_line
from jaxdpd.io.layout import (
    CHUNK_BYTES,
    FRAME_ELEMENTS,
    UNITS,
    particle_group,
    reduced_unit,
    scene_bonds,
)

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
    2) of jaxdpd.geometry.boxes.kraynik_reinelt, tilted in the x–z plane and centred on the
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
        self.particles = particle_group(handle)

    # -- opening ---------------------------------------------------------------------
    @classmethod
    def create(cls, path, scene, blocks=()) -> "H5MDWriter":
        """A new file (overwriting any, and removing its checkpoint) with the
        metadata, scene, species and bonds.

        Args:
            path: file to create.
            scene: the Scene.
            blocks: the scene's polymer ChainBlocks (their springs are stored).
        Raises:
            RunFileError: the file cannot be created (bad path, no permission).
            OutputError: writing its first parts failed (disk full, I/O error).
        """
        stale = checkpoint.checkpoint_path(path)
        try:
            handle = h5py.File(str(path), "w", rdcc_nbytes=0)
            stale.unlink(missing_ok=True)  # another run's state, if any
        except OSError as error:
            raise RunFileError(f"{path}: cannot create the output file ({error})") from None
        writer = cls(handle, scene)
        with writer._writing("creating the file"):
            writer._write_header(blocks)
        return writer

    def _write_header(self, blocks) -> None:
        handle, scene = self.file, self.scene
        h5md = handle.create_group("h5md")
        h5md.attrs["version"] = np.array([1, 1], np.int32)
        h5md.create_group("author").attrs["name"] = scene.output.author or _login()
        creator = h5md.create_group("creator")
        creator.attrs["name"] = "jaxdpd"
        creator.attrs["version"] = jaxdpd.__version__
        self._write_scene()
        handle["parameters"].attrs["run_id"] = uuid.uuid4().hex
        particles = handle.create_group(self.particles)
        box = particles.create_group("box")
        box.attrs["dimension"] = 3
        box.attrs["boundary"] = np.array([b"periodic"] * 3)
        if not scene.output.trajectory_every:  # else sampled with the frames
            edges = box.create_dataset("edges", data=np.asarray(scene.box.lengths, np.float64))
            edges.attrs["reduced_unit"] = reduced_unit("edges")
        names = scene.species_names
        counts = [s.count for s in scene.particles.species]
        species_type = h5py.enum_dtype({n: k for k, n in enumerate(names)}, basetype="i4")
        particles.create_dataset(
            "species",
            data=np.repeat(np.arange(len(names)), counts),
            dtype=species_type,
        )
        mass = particles.create_dataset(
            "mass", data=np.repeat([s.mass for s in scene.particles.species], counts)
        )
        mass.attrs["reduced_unit"] = reduced_unit("mass")
        if blocks:
            bonds = handle.create_dataset("connectivity/bonds", data=scene_bonds(scene))
            bonds.attrs["particles_group"] = particles.ref
        handle.create_group("observables", track_order=True)  # series in the run's order
        handle.flush()

    @classmethod
    def reopen(cls, path, scene, info: checkpoint.CheckpointInfo) -> "H5MDWriter":
        """An existing jaxdpd file, to continue a run from its checkpoint `info`.

        The file is checked against the checkpoint before anything is changed: it
        must be the checkpoint's run (`run_id`) and hold every time series the
        checkpoint counts, with at least as many samples, the last of them readable
        (its HDF5 chunk is the one the run appends to).  Then every series is cut to
        the checkpoint's count (samples written after it by a run that was then
        killed are dropped, so the continued run appends without duplicates), and the
        scene attribute is replaced by `scene` (e.g. with more run.steps).

        Raises:
            RunFileError: the file cannot be opened for writing, or does not hold
                what the checkpoint counts (damaged, edited, another run's).
        """
        try:
            handle = h5py.File(str(path), "r+", rdcc_nbytes=0)
        except OSError as error:
            raise RunFileError(f"{path}: cannot be opened for appending ({error})") from None
        writer = cls(handle, scene)
        try:
            groups = writer._check_against(info)
            for name, group in groups.items():
                keep = info.series.get(name, 0)
                for part in ("step", "time", "value"):
                    if part in group and group[part].shape[0] > keep:
                        group[part].resize(keep, axis=0)
            writer._write_scene()
            handle.flush()
        except (OSError, KeyError, RuntimeError) as error:
            handle.close()
            raise RunFileError(f"{path}: damaged ({first_line(error)})") from None
        except BaseException:
            handle.close()
            raise
        return writer

    def _check_against(self, info) -> dict:
        """{element path: group} of the file's series, checked against `info`."""
        path = self.path
        stored_id = self.file["parameters"].attrs.get("run_id")
        if stored_id != info.run_id:
            raise RunFileError(
                f"{path}: its checkpoint belongs to another run (run_id {info.run_id!r}, "
                f"the file's is {stored_id!r})"
            )
        groups = {group.name.lstrip("/"): group for group in time_series_groups(self.file)}
        missing = sorted(set(info.series) - set(groups))
        if missing:
            raise RunFileError(
                f"{path}: {', '.join(missing)} missing, although the checkpoint at step "
                f"{info.step} counts their samples (the file was damaged or edited); "
                "the run cannot continue without them"
            )
        for name, keep in info.series.items():
            group = groups[name]
            for part in ("step", "time", "value"):
                stored = group[part].shape[0]
                if stored < keep:
                    raise RunFileError(
                        f"{path}: {name}/{part} holds {stored} samples, the checkpoint at "
                        f"step {info.step} counts {keep} (the file was truncated or edited)"
                    )
                if keep:
                    try:
                        group[part][keep - 1]
                    except OSError:
                        raise RunFileError(
                            f"{path}: {name}/{part}: the block holding its last sample "
                            f"before the checkpoint (number {keep}) fails its checksum "
                            "(the file is corrupted there)"
                        ) from None
            if keep and group["step"][keep - 1] > info.step:
                raise RunFileError(
                    f"{path}: {name} holds step {group['step'][keep - 1]} as its sample "
                    f"{keep}, after the checkpoint's step {info.step} (corrupted)"
                )
        return groups

    def _write_scene(self) -> None:
        parameters = self.file.require_group("parameters")
        text = self.scene.to_json()
        parameters.attrs["scene"] = text
        parameters.attrs["scene_crc32"] = np.uint32(zlib.crc32(text.encode()))
        parameters.attrs["units"] = UNITS

    @property
    def run_id(self) -> str:
        """The identifier written at creation (pairs the file with its checkpoints)."""
        return str(self.file["parameters"].attrs["run_id"])

    # -- failures --------------------------------------------------------------------
    @contextlib.contextmanager
    def _writing(self, what: str):
        """Turn a failed write into OutputError, after abandoning the file (see the
        module docstring: HDF5 cannot flush or close a file after a failed write)."""
        try:
            yield
        except (OSError, RuntimeError) as error:
            self._abandon()
            raise OutputError(f"{self.path}: {what} failed ({first_line(error)})") from None

    def _abandon(self) -> None:
        """Close the file without writing to it again: its descriptor is pointed at an
        anonymous scratch file first, where HDF5's closing writes cannot fail."""
        if not self.file.id.valid:
            return
        with contextlib.suppress(Exception):
            scratch = _scratch_descriptor()
            os.dup2(scratch, self.file.id.get_vfd_handle())
            os.close(scratch)
        with contextlib.suppress(Exception):
            self.file.close()

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
        with self._writing(f"appending the observables after step {first_step}"):
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
        with self._writing(f"appending the frame of step {step}"):
            for name in FRAME_ELEMENTS:
                value = np.asarray(getattr(state, _STATE_FIELD[name]))
                group = self._series(f"{self.particles}/{name}", value.shape, value.dtype, position)
                if position is None:
                    position = group
                    self._extend(group["step"], [step])
                    self._extend(group["time"], [step * self.scene.step_time])
                self._extend(group["value"], value[None])
            edges = np.asarray(edges, np.float64)
            box_edges = self._series(
                f"{self.particles}/box/edges", edges.shape, edges.dtype, position
            )
            self._extend(box_edges["value"], edges[None])

    # -- run results -----------------------------------------------------------------
    def write_rdf(self, r, g, samples: int) -> None:
        """(Re)write the radial distribution function averaged over `samples` frames."""
        with self._writing("writing g(r)"):
            if "averages/rdf" in self.file:
                del self.file["averages/rdf"]
            group = self.file.create_group("averages/rdf")
            group.create_dataset("r", data=r).attrs["reduced_unit"] = "r_c"
            group.create_dataset("g", data=g).attrs["reduced_unit"] = "1"
            group.attrs["samples"] = samples

    def write_warning(self, name: str, message: str | None) -> None:
        """Set (or, with None, remove) the `warning` attribute of observables/<name>: a
        sanity check of the run's averages that failed (jaxdpd.analysis.temperature_check)."""
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
        values = np.asarray(values)
        with self._writing(f"writing {path}"):
            if path in self.file:
                del self.file[path]
            group = self.file.create_group(path)
            group.create_dataset("lag_time", data=np.asarray(lag_times, np.float64))
            group.create_dataset("value", data=values.reshape(len(values), -1).mean(axis=1))
            group.create_dataset("per_element", data=values)
            for part in ("lag_time", "value", "per_element"):
                unit = reduced_unit(path if part != "lag_time" else part)
                if unit:
                    group[part].attrs["reduced_unit"] = unit

    def write_checkpoint(self, state, phase: str, reason: str, extras=None) -> None:
        """Write the checkpoint file (jaxdpd.io.checkpoint): first this file is flushed
        and fsynced, so every sample the checkpoint counts is on disk, then the
        checkpoint replaces the previous one atomically.

        Raises:
            OutputError: either write failed; the previous checkpoint is intact.
        """
        step = int(state.step)
        with self._writing(f"flushing before the checkpoint of step {step}"):
            self.file.flush()
            os.fsync(self.file.id.get_vfd_handle())
            series = {g.name.lstrip("/"): len(g["value"]) for g in time_series_groups(self.file)}
        target = checkpoint.checkpoint_path(self.path)
        try:
            checkpoint.write_checkpoint(
                target, state, phase, reason, self.run_id, self.scene.to_dict(), series, extras
            )
        except OSError as error:
            raise OutputError(
                f"{target}: writing the checkpoint of step {step} failed "
                f"({first_line(error)}); the previous checkpoint is intact"
            ) from None

    def flush(self) -> None:
        """Push everything written so far to the operating system."""
        with self._writing("flushing"):
            self.file.flush()

    def close(self) -> None:
        """Flush and close (idempotent)."""
        if self.file.id.valid:
            self.flush()
            self.file.close()

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()


def _scratch_descriptor() -> int:
    """A new descriptor of an anonymous file: in memory on Linux, else an unlinked
    temporary file."""
    if hasattr(os, "memfd_create"):
        return os.memfd_create("jaxdpd-abandoned")
    with tempfile.TemporaryFile() as scratch:
        return os.dup(scratch.fileno())


_STATE_FIELD = {"position": "positions", "velocity": "velocities", "image": "image"}


def _login() -> str:
    try:
        return getpass.getuser()
    except (KeyError, OSError):
        return "unknown"
