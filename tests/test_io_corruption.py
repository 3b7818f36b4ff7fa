"""Missing, truncated, damaged or foreign files and bad scene files are refused with
one line naming the problem: RunFileError from the readers, exit status 2 from the
command line, never a traceback from inside h5py or JAX."""

import json
import re
import shutil

import h5py
import pytest
from io_runs import SCENE_TOML, reference_run

from jaxdpd.cli import main
from jaxdpd.io import RunFileError, read_scene, read_state


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


def _edit(change):
    def damage(path):
        with h5py.File(path, "r+") as handle:
            change(handle)

    return damage


def _scene_json(handle):
    data = json.loads(handle["parameters"].attrs["scene"])
    data["seed"] = -1
    handle["parameters"].attrs["scene"] = json.dumps(data)


def _flip_in(dataset_path: str):
    def damage(path):
        with h5py.File(path, "r") as handle:
            dataset = handle[dataset_path]
            offset = (
                dataset.id.get_offset()
                if dataset.chunks is None
                else dataset.id.get_chunk_info(0).byte_offset
            )
        _flip_byte(path, offset + 5)

    return damage


DAMAGE = {
    "missing": (lambda path: path.unlink(), "no such file"),
    "truncated": (_truncate, "not a readable HDF5 file"),
    "not HDF5": (_not_hdf5, "not a readable HDF5 file"),
    "foreign HDF5": (_foreign, "not a jaxdpd file"),
    "scene not JSON": (
        _edit(lambda h: h["parameters"].attrs.__setitem__("scene", "{seed")),
        "stored scene is not valid JSON",
    ),
    "scene invalid": (_edit(_scene_json), r"stored scene is invalid \(seed = -1"),
    "no checkpoint": (_edit(lambda h: h.__delitem__("checkpoint")), "holds no checkpoint"),
    "checkpoint incomplete": (
        _edit(lambda h: h["checkpoint"].attrs.__setitem__("complete", False)),
        "checkpoint is incomplete",
    ),
    "leaf damaged": (_flip_in("checkpoint/state/positions"), "positions fails its checksum"),
    "leaf missing": (
        _edit(lambda h: h.__delitem__("checkpoint/state/velocities")),
        "velocities is missing",
    ),
    "series damaged": (_flip_in("observables/temperature/value"), "stored series is damaged"),
    "series cut short": (
        _edit(lambda h: h["observables/pressure/value"].resize(7, axis=0)),
        r"observables/pressure does not hold steps 1…2400",
    ),
}


@pytest.mark.parametrize("case", list(DAMAGE))
def test_a_damaged_file_is_refused_by_restart_with_one_line_and_exit_2(case, tmp_path, capsys):
    damage, message = DAMAGE[case]
    path = tmp_path / "run.h5"
    shutil.copyfile(reference_run().path, path)
    damage(path)
    assert main(["run", "--restart", str(path), "-q"]) == 2
    error = capsys.readouterr().err.strip()
    assert len(error.splitlines()) == 1, error
    assert error.startswith("jaxdpd: invalid input: ") and str(path) in error
    assert re.search(message, error), error


@pytest.mark.parametrize("case", ["truncated", "scene invalid", "leaf damaged"])
def test_readers_raise_run_file_errors_for_damaged_files(case, tmp_path):
    damage, message = DAMAGE[case]
    path = tmp_path / "run.h5"
    shutil.copyfile(reference_run().path, path)
    damage(path)
    reader = read_state if case == "leaf damaged" else read_scene
    with pytest.raises(RunFileError, match=message):
        reader(path)


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


def test_a_new_run_refuses_to_overwrite_an_unfinished_one(tmp_path, capsys):
    path = tmp_path / "run.h5"
    shutil.copyfile(reference_run().path, path)
    with h5py.File(path, "r+") as handle:
        handle["checkpoint"].attrs["reason"] = "interrupted by SIGINT"
    scene_file = tmp_path / "scene.toml"
    scene_file.write_text(SCENE_TOML)
    assert main(["run", str(scene_file), "-o", str(path)]) == 2
    error = capsys.readouterr().err
    assert f"jaxdpd run --restart {path}" in error and "--overwrite" in error
