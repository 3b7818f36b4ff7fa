"""Missing, truncated, damaged, edited or foreign files and bad scene files are
refused with one line naming the problem: RunFileError from the readers, exit status
2 from the command line, never a traceback from inside h5py or JAX.  A refused
restart leaves the file as it found it."""

import json
import re
import zlib

import h5py
import numpy as np
import pytest
from io_runs import SCENE_TOML, copy_run, reference_run

from jaxdpd.io import RunFileError, load, read_checkpoint, read_scene, write_tree
from jaxdpd.io.checkpoint import checkpoint_path
from jaxdpd.run.cli import main
from jaxdpd.run.restore import restore


def _flip_byte(path, offset: int) -> None:
    with open(path, "r+b") as raw:
        raw.seek(offset)
        byte = raw.read(1)
        raw.seek(offset)
        raw.write(bytes([byte[0] ^ 0xFF]))


def _truncate(path):
    size = path.stat().st_size
    with open(path, "r+b") as raw:
        raw.truncate(size // 2)


def _not_hdf5(path):
    path.write_text(SCENE_TOML)


def _foreign(path):
    with h5py.File(path, "w") as handle:
        handle["data"] = [1, 2, 3]


def _edit(change, which=lambda path: path):
    """Edit the run file (or, with which=checkpoint_path, its checkpoint) with h5py."""

    def damage(path):
        with h5py.File(which(path), "r+") as handle:
            change(handle)

    return damage


def _in_checkpoint(damage):
    return lambda path: damage(checkpoint_path(path))


def _set_scene(handle, text: str) -> None:
    """Replace the stored scene and its checksum (an edit the checksum cannot see)."""
    handle["parameters"].attrs["scene"] = text
    handle["parameters"].attrs["scene_crc32"] = np.uint32(zlib.crc32(text.encode()))


def _scene_json(handle):
    data = json.loads(handle["parameters"].attrs["scene"])
    data["seed"] = -1
    _set_scene(handle, json.dumps(data))


def _scene_digit(path):
    """One digit of the scene changed in the file's raw bytes (γ = 4.5 → 4.7)."""
    raw = path.read_bytes()
    assert raw.count(b'"gamma": 4.5') == 1
    path.write_bytes(raw.replace(b'"gamma": 4.5', b'"gamma": 4.7'))


def _flip_in(dataset_path: str, chunk: int = 0):
    def damage(path):
        with h5py.File(path, "r") as handle:
            dataset = handle[dataset_path]
            if dataset.chunks is None:
                offset = dataset.id.get_offset()
            else:
                chunks = dataset.id.get_num_chunks()
                offset = dataset.id.get_chunk_info(chunk % chunks).byte_offset
        _flip_byte(path, offset + 5)

    return damage


def set_checkpoint_header(path, **changes) -> None:
    """Rewrite fields of a checkpoint's header with a valid checksum."""
    with h5py.File(checkpoint_path(path), "r+") as handle:
        header = json.loads(handle.attrs["header"]) | changes
        text = json.dumps(header, sort_keys=True)
        handle.attrs["header"] = text
        handle.attrs["header_crc32"] = np.uint32(zlib.crc32(text.encode()))


def _header_byte(handle):
    handle.attrs["header"] = handle.attrs["header"].replace('"step": 2400', '"step": 2300')


DAMAGE = {
    "missing": (lambda path: path.unlink(), "no such file"),
    "truncated": (_truncate, "not a readable HDF5 file"),
    "not HDF5": (_not_hdf5, "not a readable HDF5 file"),
    "foreign HDF5": (_foreign, "not a jaxdpd file"),
    "scene digit changed": (_scene_digit, r"stored scene \(/parameters:scene\) fails its checksum"),
    "scene not JSON": (
        _edit(lambda h: _set_scene(h, "{seed")),
        "stored scene is not valid JSON",
    ),
    "scene invalid": (_edit(_scene_json), r"stored scene is invalid \(seed = -1"),
    "no checkpoint": (lambda path: checkpoint_path(path).unlink(), "has no checkpoint"),
    "checkpoint truncated": (_in_checkpoint(_truncate), "checkpoint: not a readable HDF5 file"),
    "checkpoint header edited": (
        _edit(_header_byte, checkpoint_path),
        "checkpoint header fails its checksum",
    ),
    "another run's checkpoint": (
        lambda path: set_checkpoint_header(path, run_id="0" * 32),
        "belongs to another run",
    ),
    "leaf damaged": (
        _in_checkpoint(_flip_in("state/positions")),
        "positions fails its checksum",
    ),
    "leaf missing": (
        _edit(lambda h: h.__delitem__("state/velocities"), checkpoint_path),
        "velocities is missing",
    ),
    "unknown accumulator": (
        _edit(lambda h: write_tree(h["extras"], {"x": np.ones(1)}), checkpoint_path),
        r"holds the accumulators \['x'\], this scene needs \[\]",
    ),
    "series damaged": (
        _flip_in("observables/temperature/value"),
        "observables/temperature/value: the block holding its last sample",
    ),
    "series deleted": (
        _edit(lambda h: h.__delitem__("observables/temperature")),
        "observables/temperature missing, although the checkpoint at step 2400 counts",
    ),
    "series cut short": (
        _edit(lambda h: h["observables/pressure/value"].resize(7, axis=0)),
        r"observables/pressure/value holds 7 samples, the checkpoint at step 2400 counts 2400",
    ),
    "last frame block damaged": (
        _flip_in("particles/trajectory/position/value", chunk=-1),
        "particles/trajectory/position/value: the block holding its last sample",
    ),
}


@pytest.mark.parametrize("case", list(DAMAGE))
def test_a_damaged_file_is_refused_by_restart_with_one_line_and_exit_2(case, tmp_path, capsys):
    damage, message = DAMAGE[case]
    path = tmp_path / "run.h5"
    copy_run(reference_run().path, path)
    before = path.read_bytes() if path.exists() else None
    damage(path)
    damaged = path.read_bytes() if path.exists() else None
    capsys.readouterr()  # drop what the shared reference run printed, if it ran here
    assert main(["run", "--restart", str(path), "-q"]) == 2
    error = capsys.readouterr().err.strip()
    assert len(error.splitlines()) == 1, error
    assert error.startswith("jaxdpd: invalid input: ") and str(path) in error
    assert re.search(message, error), error
    if before is not None and damaged is not None:  # refused before changing anything
        assert path.read_bytes() == damaged


READERS = {
    "truncated": read_scene,
    "scene invalid": read_scene,
    "scene digit changed": read_scene,
    "leaf damaged": restore,
    "checkpoint header edited": read_checkpoint,
    "another run's checkpoint": load,
}


@pytest.mark.parametrize("case", list(READERS))
def test_readers_raise_run_file_errors_for_damaged_files(case, tmp_path):
    damage, message = DAMAGE[case]
    path = tmp_path / "run.h5"
    copy_run(reference_run().path, path)
    damage(path)
    with pytest.raises(RunFileError, match=message):
        READERS[case](path)


SCENE_FILES = {
    "wrong type": ("[particles]\ncount = 'many'\ndensity = 3.0", "particles.count"),
    "unknown key": ("[particles]\ncount = 300\ndensity = 3.0\ndensty = 3.0", "densty"),
    "out of range": ("[particles]\ncount = 300\ndensity = -3.0", "particles.density = -3.0"),
    "not TOML": ("[particles\ncount = 300", "not valid TOML"),
}


@pytest.mark.parametrize("case", list(SCENE_FILES))
def test_a_bad_scene_file_exits_2_with_one_line_naming_the_field(case, tmp_path, capsys):
    text, named = SCENE_FILES[case]
    scene_file = tmp_path / "scene.toml"
    scene_file.write_text(f'{text}\n[solvent]\nmethod = "dpd"\n')
    assert main(["run", str(scene_file)]) == 2
    error = capsys.readouterr().err.strip()
    assert len(error.splitlines()) == 1 and named in error, error


@pytest.mark.parametrize(
    "argv, named",
    [
        (["run"], "give a scene file"),
        (["run", "scene.toml", "--restart", "run.h5"], "not both"),
        (["run", "absent.toml"], "absent.toml"),
    ],
)
def test_bad_command_lines_exit_2_with_one_line(argv, named, tmp_path, capsys, monkeypatch):
    monkeypatch.chdir(tmp_path)
    assert main(argv) == 2
    error = capsys.readouterr().err.strip()
    assert len(error.splitlines()) == 1 and named in error, error


def test_a_scene_file_that_is_not_utf8_is_refused_naming_it(tmp_path, capsys):
    scene_file = tmp_path / "latin1.toml"
    scene_file.write_bytes("# γ\n[particles]\ncount = 300\n".encode("latin-1", "replace") + b"\xff")
    assert main(["run", str(scene_file)]) == 2
    error = capsys.readouterr().err.strip()
    assert len(error.splitlines()) == 1 and f"{scene_file}: not UTF-8" in error, error


def test_a_new_run_refuses_to_overwrite_an_unfinished_one(tmp_path, capsys):
    path = tmp_path / "run.h5"
    copy_run(reference_run().path, path)
    set_checkpoint_header(path, reason="interrupted by SIGINT")
    scene_file = tmp_path / "scene.toml"
    scene_file.write_text(SCENE_TOML)
    assert main(["run", str(scene_file), "-o", str(path)]) == 2
    error = capsys.readouterr().err
    assert f"jaxdpd run --restart {path}" in error and "--overwrite" in error
