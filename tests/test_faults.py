"""Fault injection with real processes: `jaxdpd run` killed (SIGKILL) inside a
checkpoint, and a file system that fills up under a run.

Each fault is injected at a chosen checkpoint by tests/fault_driver.py, which runs
the command line in a subprocess with os.write, os.replace or os.fsync wrapped (no
timing luck, no hook in the library).  The run is then resumed with
`jaxdpd run --restart` and must end bit-identical to the uninterrupted run
(io_runs.polymer_reference_run: the same scene, compiled on the same CPU).  The
polymer scene checkpoints at steps 30 (equilibration), 70, 100, 130 and 140 (the
end), so a fault at the third checkpoint must leave the second, step 70.

The cheap, in-process part of the fault suite runs by default: in test_restart.py a
checkpoint write that fails, a full disk simulated with /dev/full, wall-clock
checkpoints and a checkpoint without its g(r); in test_io_corruption.py damaged,
edited and incomplete files (scene, observables, frames, checkpoint).
"""

import os
import signal
import subprocess
import sys
from pathlib import Path

import pytest
from io_runs import POLYMER_SCENE_TOML, assert_same_run, polymer_reference_run

from jaxdpd.io import read_checkpoint
from jaxdpd.io.checkpoint import checkpoint_path
from jaxdpd.run.cli import main

TESTS = Path(__file__).resolve().parent
pytestmark = [
    pytest.mark.slow,
    pytest.mark.skipif(not Path("/proc/self/fd").exists(), reason="needs /proc (Linux)"),
]


def _drive(fault: str, checkpoint: int, output: Path, folder: Path):
    """Run the polymer scene into `output` with `fault` at the given checkpoint."""
    scene_file = folder / "scene.toml"
    scene_file.write_text(POLYMER_SCENE_TOML)
    environment = dict(os.environ)
    environment["PYTHONPATH"] = os.pathsep.join(
        p for p in (str(TESTS.parent), environment.get("PYTHONPATH")) if p
    )
    command = [sys.executable, str(TESTS / "fault_driver.py"), fault, str(checkpoint)]
    return subprocess.run(
        [*command, str(scene_file), str(output)],
        cwd=folder,
        env=environment,
        capture_output=True,
        timeout=900,
    )


@pytest.mark.parametrize(
    "fault", ["kill-writing-checkpoint", "kill-before-rename", "kill-syncing-output"]
)
def test_a_run_killed_inside_its_third_checkpoint_resumes_from_the_second(fault, tmp_path):
    reference = polymer_reference_run()
    output = tmp_path / "run.h5"
    result = _drive(fault, 3, output, tmp_path)
    assert result.returncode == -signal.SIGKILL, result.stderr.decode()[-3000:]
    checkpoint = read_checkpoint(output)
    assert (checkpoint["step"], checkpoint["reason"]) == (70, "periodic")
    temporary = Path(f"{checkpoint_path(output)}.tmp")
    assert temporary.exists() == (fault != "kill-syncing-output")  # the half-written one
    assert main(["run", "--restart", str(output), "-q"]) == 0
    assert_same_run(output, reference)
    assert not temporary.exists()


def test_a_full_file_system_stops_the_run_with_status_4_and_it_resumes_once_freed(tmp_path):
    """A 16 MiB tmpfs, filled up by a filler file once the third checkpoint (step 100)
    is in place: the run stops with exit status 4 and a message naming the failure and
    the intact checkpoint (no traceback, no segmentation fault); with the filler
    removed, the restart completes the run."""
    reference = polymer_reference_run()
    folder = tmp_path / "small"
    folder.mkdir()
    mount = ["mount", "-t", "tmpfs", "-o", "size=16m", "tmpfs", str(folder)]
    mounted = subprocess.run(mount, capture_output=True)
    if mounted.returncode:
        pytest.skip(f"cannot mount a tmpfs here: {mounted.stderr.decode().strip()}")
    try:
        output = folder / "run.h5"
        result = _drive("fill-disk", 3, output, tmp_path)
        message = result.stderr.decode()
        assert result.returncode == 4, message[-3000:]
        assert "No space left on device" in message and "Traceback" not in message
        assert "the checkpoint of step 100" in message
        assert f"jaxdpd run --restart {output}" in message
        assert read_checkpoint(output)["step"] == 100
        (folder / "filler").unlink()
        assert main(["run", "--restart", str(output), "-q"]) == 0
        assert_same_run(output, reference)
    finally:
        subprocess.run(["umount", str(folder)], check=False)
