"""A new run never replaces an existing output file unless told to (jaxdpd.run.overwrite):
`jaxdpd run`, `jaxdpd demo`, `jaxdpd run --restart FILE -o COPY` and the Python
runner refuse, before building anything, with one message naming the file, what it
holds and the options; `--overwrite` / overwrite=True replaces it."""

import pytest
from conftest import make_scene

from jaxdpd.io.checkpoint import checkpoint_path, read_checkpoint_info
from jaxdpd.run.cli import main
from jaxdpd.run.runner import simulate

SCENE = {"run": {"steps": 20, "chunk": 10, "equilibration": 0}}


def contents(path) -> list[bytes]:
    return [path.read_bytes(), checkpoint_path(path).read_bytes()]


def test_a_finished_run_is_kept_and_the_message_names_the_ways_on(tmp_path, capsys):
    scene = make_scene(**SCENE)
    path = tmp_path / "run.h5md"
    simulate(scene, path, progress=False)
    capsys.readouterr()
    before = contents(path)
    with pytest.raises(FileExistsError, match="a finished run, checkpointed at step 20"):
        simulate(scene, path, progress=False)
    scene_file = tmp_path / "scene.toml"
    scene_file.write_text(
        '[particles]\ndensity = 3.0\ncount = 600\n[solvent]\nmethod = "dpd"\n'
        "[run]\nsteps = 20\nchunk = 10\n"
    )
    copy = tmp_path / "copy.h5md"
    copy.write_bytes(b"someone's notes")
    commands = (
        ["run", str(scene_file), "-o", str(path), "-q"],
        ["demo", "-o", str(path), "-q"],
        ["run", "--restart", str(path), "-o", str(copy), "-q"],
    )
    for command in commands:
        assert main(command) == 2, command
        error = capsys.readouterr().err.strip()
        assert len(error.splitlines()) == 1, error
        assert "--overwrite" in error and "-o FILE" in error, error
    # The last refusal is of COPY, which is no run: nothing to continue it from.
    assert f"{copy} already exists (no jaxdpd checkpoint beside it" in error
    assert "--restart" not in error
    assert contents(path) == before and copy.read_bytes() == b"someone's notes"
    for command in commands[:2]:
        main(command)
        assert f"jaxdpd run --restart {path}" in capsys.readouterr().err
    # Replacing is a choice: a new run, with a new run identifier.
    old_run = read_checkpoint_info(path).run_id
    simulate(scene, path, progress=False, overwrite=True)
    assert read_checkpoint_info(path).run_id != old_run
