"""Interrupted runs continue bit-for-bit, and nothing written is lost or duplicated.

The reference is the same scene run uninterrupted (io_runs).  "The same" means: every
leaf of the final SimState (neighbour list included) bit-identical, every stored
series and frame equal element for element with the same steps, g(r) equal, and
the summary's block averages equal.  Integration is deterministic (counter-based
noise, jaxdpd.engine.noise; the same compiled step on the same CPU), so no tolerance is
needed.
"""

import errno
import itertools
import os
import re
import shlex
import signal
import subprocess
import sys
import threading
import time
from pathlib import Path

import h5py
import numpy as np
import pytest
from io_runs import (
    SCENE_TOML,
    assert_same_leaves,
    assert_same_run,
    copy_run,
    polymer_reference_run,
    polymer_scene,
    reference_run,
)

from jaxdpd.io import RunFileError, checkpoint, read_checkpoint, read_observables, read_trajectory
from jaxdpd.io.checkpoint import checkpoint_path
from jaxdpd.io.errors import OutputError
from jaxdpd.io.h5md import H5MDWriter
from jaxdpd.run import runner
from jaxdpd.run.cli import main
from jaxdpd.run.driver import RunInterrupted, SignalGuard
from jaxdpd.run.runner import prepare, resume, simulate

REPOSITORY = Path(__file__).resolve().parents[1]


class _StderrReader(threading.Thread):
    """Collects a subprocess's stderr as it comes (the progress bar has no newlines)."""

    def __init__(self, stream):
        super().__init__(daemon=True)
        self.stream, self.data = stream, b""

    def run(self):
        while chunk := os.read(self.stream.fileno(), 4096):
            self.data += chunk

    def wait_for_steps(self, done: int, total: int, process, timeout: float) -> None:
        """Wait until the progress bar shows at least `done` of `total` steps."""
        deadline = time.monotonic() + timeout
        pattern = re.compile(rb"(\d+)/%d steps" % total)
        while time.monotonic() < deadline and process.poll() is None:
            shown = [int(n) for n in pattern.findall(self.data)]
            if shown and max(shown) >= done:
                return
            time.sleep(0.005)
        raise AssertionError(f"no progress to {done} steps: {self.data.decode()[-2000:]}")


def test_sigint_to_a_cli_run_then_restart_ends_bit_identical_in_float64(tmp_path, capsys):
    """A real `jaxdpd run` subprocess gets SIGINT once it has written two chunks; it
    finishes the chunk in flight, checkpoints, exits 130 and prints the command that
    resumes it; that command completes the run.  The child starts with SIGINT
    ignored, as a job started in the background by a shell script does: jaxdpd
    handles it all the same."""
    reference = reference_run()
    scene = reference.scene
    assert scene.precision == "float64"
    scene_file, output = tmp_path / "scene.toml", tmp_path / "run.h5"
    scene_file.write_text(SCENE_TOML)
    environment = dict(os.environ)
    environment["PYTHONPATH"] = os.pathsep.join(
        p for p in (str(REPOSITORY), environment.get("PYTHONPATH")) if p
    )
    command = [sys.executable, "-m", "jaxdpd.run.cli", "run", str(scene_file), "-o", str(output)]
    process = subprocess.Popen(
        # The shell ignores SIGINT, and exec keeps it ignored, as in a background job.
        ["sh", "-c", 'trap "" INT; exec "$@"', "sh", *command],
        cwd=tmp_path,
        env=environment,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
    )
    reader = _StderrReader(process.stderr)
    reader.start()
    try:
        reader.wait_for_steps(2 * scene.run.chunk, scene.run.steps, process, timeout=300)
        process.send_signal(signal.SIGINT)
        process.wait(timeout=300)
    finally:
        process.kill()
    reader.join(timeout=10)
    message = reader.data.decode()
    assert process.returncode == 128 + signal.SIGINT, message
    stopped = int(re.search(r"interrupted by SIGINT at step (\d+)", message).group(1))
    assert 2 * scene.run.chunk <= stopped < scene.run.steps and stopped % scene.run.chunk == 0
    checkpoint = read_checkpoint(output)
    assert (checkpoint["step"], checkpoint["reason"]) == (stopped, "interrupted by SIGINT")
    assert read_observables(output)["temperature"].step[-1] == stopped
    command = re.search(r"resume with:\n\s*(.+)\n", message).group(1)
    argv = shlex.split(command)
    assert argv[:3] == ["jaxdpd", "run", "--restart"]
    assert main(argv[1:]) == 0
    assert_same_run(output, reference)
    # The summary covers the whole production (the stored part replayed): the same
    # table as the uninterrupted run's, but for the stepping rate (absent after a
    # single resumed chunk).
    printed = capsys.readouterr().out.splitlines()
    table = printed[: printed.index(next(p for p in printed if p.startswith("total wall")))]
    expected = reference.summary.table().splitlines()
    rate = "particle-steps/s"
    assert [line for line in table if not line.startswith(rate)] == [
        line for line in expected if not line.startswith(rate)
    ]


def test_the_signal_guard_records_the_first_signal_and_restores_the_handlers():
    previous = signal.getsignal(signal.SIGTERM)
    with SignalGuard() as guard:
        assert guard() is None
        os.kill(os.getpid(), signal.SIGTERM)
        time.sleep(0.01)  # the Python handler runs between bytecodes of this thread
        assert guard() == "SIGTERM"
        # A second signal would now take its default action: terminate at once.
        assert signal.getsignal(signal.SIGTERM) is signal.SIG_DFL
        assert signal.getsignal(signal.SIGINT) is signal.SIG_DFL
    assert signal.getsignal(signal.SIGTERM) is previous


def test_the_signal_guard_handles_a_signal_that_was_ignored_and_ignores_it_again():
    previous = signal.signal(signal.SIGTERM, signal.SIG_IGN)  # as in a background job
    try:
        with SignalGuard() as guard:
            os.kill(os.getpid(), signal.SIGTERM)
            time.sleep(0.01)
            assert guard() == "SIGTERM"
        assert signal.getsignal(signal.SIGTERM) is signal.SIG_IGN
    finally:
        signal.signal(signal.SIGTERM, previous)


class _SignalAfter:
    """A progress stream that sends `signum` to this process once the bar shows
    `steps` steps done (a signal arriving during the run, from inside it)."""

    def __init__(self, steps: int, signum):
        self.pattern, self.signum, self.sent = re.compile(rf"\] {steps}/"), signum, False

    def write(self, text):
        if not self.sent and self.pattern.search(text):
            self.sent = True
            os.kill(os.getpid(), self.signum)

    def flush(self):
        pass


def test_sigterm_during_equilibration_stops_with_a_checkpoint_and_resume_matches(tmp_path):
    reference = polymer_reference_run()
    path = tmp_path / "run.h5"
    previous = signal.getsignal(signal.SIGTERM)
    with pytest.raises(RunInterrupted, match="SIGTERM at step 20"):
        simulate(polymer_scene(), path, stream=_SignalAfter(20, signal.SIGTERM))
    assert signal.getsignal(signal.SIGTERM) is previous  # handlers put back
    checkpoint = read_checkpoint(path)
    assert (checkpoint["phase"], checkpoint["step"]) == ("equilibration", 20)
    assert read_observables(path) == {}
    summary = resume(path, progress=False)
    assert_same_run(path, reference)
    assert summary.averages == reference.summary.averages


class _Crash(RuntimeError):
    pass


def test_a_crash_between_checkpoints_loses_nothing_and_duplicates_nothing(tmp_path):
    """The process dies (here: an exception from the chunk hook) after writing series
    and a frame past its last periodic checkpoint; resuming drops them and rewrites
    them, so every series holds each step once."""
    reference = polymer_reference_run()
    scene = reference.scene
    path = tmp_path / "run.h5"
    crash_at = scene.run.equilibration + 50  # checkpoints every 30 steps: last one at +30

    def crash(result):
        if int(result.state.step) == crash_at:
            raise _Crash

    with pytest.raises(_Crash):
        simulate(scene, path, progress=False, on_chunk=crash)
    checkpoint = read_checkpoint(path)
    assert (checkpoint["reason"], checkpoint["step"]) == ("periodic", crash_at - 20)
    assert read_observables(path)["temperature"].step[-1] == crash_at
    assert read_trajectory(path).step[-1] == crash_at - 10
    resume(path, progress=False)
    assert_same_run(path, reference)


def test_sigint_in_production_then_cli_restart_matches(tmp_path):
    reference = polymer_reference_run()
    scene = reference.scene
    path = tmp_path / "run.h5"
    previous = signal.getsignal(signal.SIGINT)
    stop_after = scene.run.equilibration + 60

    def interrupt(result):
        if int(result.state.step) == stop_after:
            os.kill(os.getpid(), signal.SIGINT)

    with pytest.raises(RunInterrupted, match=f"SIGINT at step {stop_after}"):
        simulate(scene, path, progress=False, on_chunk=interrupt)
    assert signal.getsignal(signal.SIGINT) is previous
    assert read_checkpoint(path)["phase"] == "production"
    assert main(["run", "--restart", str(path), "-q"]) == 0
    assert_same_run(path, reference)


def test_resuming_a_finished_run_appends_nothing(tmp_path):
    reference = polymer_reference_run()
    path = tmp_path / "copy.h5"
    copy_run(reference.path, path)
    summary = resume(path, progress=False)
    assert_same_run(path, reference)
    assert summary.averages == reference.summary.averages


def test_restart_into_a_copy_takes_the_checkpoint_along_and_keeps_the_original(tmp_path):
    """`jaxdpd run --restart FILE -o COPY` continues in COPY (with its own checkpoint
    file); FILE and its checkpoint are left as they were."""
    reference = polymer_reference_run()
    original, copy = tmp_path / "run.h5", tmp_path / "copy.h5"
    copy_run(reference.path, original)
    before = [p.read_bytes() for p in (original, checkpoint_path(original))]
    assert main(["run", "--restart", str(original), "-o", str(copy), "-q"]) == 0
    assert_same_run(copy, reference)
    assert [p.read_bytes() for p in (original, checkpoint_path(original))] == before


@pytest.mark.slow
def test_a_finished_run_extended_with_more_steps_equals_a_longer_run(tmp_path):
    """`resume(path, steps=...)` (CLI: --restart FILE --steps N) continues a finished
    run; the result equals a run of the longer length from the start."""
    reference = polymer_reference_run()
    longer = polymer_scene().replace(run={"steps": 150})
    direct = simulate(longer, tmp_path / "direct.h5", progress=False)
    path = tmp_path / "extended.h5"
    copy_run(reference.path, path)
    with pytest.raises(ValueError, match="at least 100"):
        resume(path, steps=90, progress=False)
    extended = resume(path, steps=150, progress=False)
    assert_same_leaves(extended.state, direct.state)
    assert extended.averages == direct.averages
    ours, theirs = read_observables(path), read_observables(tmp_path / "direct.h5")
    for name in theirs:
        np.testing.assert_array_equal(ours[name].value, theirs[name].value)


@pytest.mark.slow
def test_a_jax_md_neighbour_list_run_interrupted_and_resumed_matches(tmp_path):
    """jax-md's neighbour list state holds functions and an enum as static fields:
    the checkpoint takes them from the rebuilt scene and the run still continues
    bit-identically (float32, ordered-sparse list)."""
    scene = polymer_scene().replace(neighbors={"method": "jax_md", "format": "ordered_sparse"})
    direct = simulate(scene, tmp_path / "direct.h5", progress=False)
    path = tmp_path / "run.h5"
    stop_after = scene.run.equilibration + 30

    def interrupt(result):
        if int(result.state.step) == stop_after:
            os.kill(os.getpid(), signal.SIGTERM)

    with pytest.raises(RunInterrupted):
        simulate(scene, path, progress=False, on_chunk=interrupt)
    resumed = resume(path, progress=False)
    assert_same_leaves(resumed.state, direct.state)
    assert resumed.averages == direct.averages


# -- faults: the cheap, in-process part (tests/test_faults.py kills real processes) --


def _checkpoints_written(monkeypatch) -> list:
    """(step, reason) of every checkpoint the writer is asked for, from now on."""
    written = []
    original = H5MDWriter.write_checkpoint

    def record(self, state, phase, reason, extras=None):
        written.append((int(state.step), reason))
        original(self, state, phase, reason, extras)

    monkeypatch.setattr(H5MDWriter, "write_checkpoint", record)
    return written


def test_a_checkpoint_is_written_every_checkpoint_seconds_of_wall_time(tmp_path, monkeypatch):
    """A clock that advances by output.checkpoint_seconds at every reading: a
    periodic checkpoint at every chunk end, beside those every checkpoint_every steps."""
    scene = polymer_scene()
    ticks = itertools.count(0.0, scene.output.checkpoint_seconds)
    monkeypatch.setattr(runner.time, "monotonic", lambda: next(ticks))
    written = _checkpoints_written(monkeypatch)
    simulate(scene, tmp_path / "run.h5", progress=False)
    chunk, total = scene.run.chunk, scene.run.equilibration + scene.run.steps
    assert written == [(step, "periodic") for step in range(chunk, total + 1, chunk)] + [
        (total, "end of run")
    ]


def test_a_checkpoint_write_that_fails_leaves_the_previous_checkpoint(tmp_path, monkeypatch):
    """The third checkpoint's file cannot be renamed into place (ENOSPC raised where
    the rename happens): OutputError names it; the second checkpoint is intact and
    resuming from it ends as the uninterrupted run."""
    reference = polymer_reference_run()
    path = tmp_path / "run.h5"
    replace, renames = os.replace, []

    def failing_replace(source, target):
        if str(target).endswith(".checkpoint"):
            renames.append(target)
            if len(renames) == 3:
                raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))
        replace(source, target)

    monkeypatch.setattr(checkpoint.os, "replace", failing_replace)
    with pytest.raises(OutputError, match=r"run.h5.checkpoint: writing the checkpoint of step 100"):
        simulate(reference.scene, path, progress=False)
    monkeypatch.undo()
    assert read_checkpoint(path)["step"] == 70
    assert sorted(p.name for p in tmp_path.iterdir()) == ["run.h5", "run.h5.checkpoint"]
    resume(path, progress=False)
    assert_same_run(path, reference)


def test_a_full_disk_under_the_output_file_stops_the_run_and_it_resumes_later(tmp_path):
    """ENOSPC simulated: after the chunk that ends at step 90, the output file's
    descriptor is pointed at /dev/full.  The next write fails: OutputError, no crash,
    the checkpoint of step 70 intact; the file on disk resumes from it."""
    reference = polymer_reference_run()
    path = tmp_path / "run.h5"

    def fill_disk(result):
        if int(result.state.step) == 90:
            full = os.open("/dev/full", os.O_RDWR)
            os.dup2(full, run.writer.file.id.get_vfd_handle())
            os.close(full)

    run = prepare(reference.scene, path, progress=False, on_chunk=fill_disk)
    with pytest.raises(OutputError, match=r"run.h5: appending the observables after step 90"):
        run.execute()
    assert read_checkpoint(path)["step"] == 70
    resume(path, progress=False)
    assert_same_run(path, reference)


def test_a_restart_without_the_checkpointed_g_of_r_is_refused(tmp_path):
    """g(r) is accumulated on the host and kept in the checkpoint only: without it
    the run's g(r) cannot be completed, so the restart refuses (exit status 2)."""
    path = tmp_path / "run.h5"
    copy_run(polymer_reference_run().path, path)
    with h5py.File(checkpoint_path(path), "r+") as handle:
        del handle["extras/rdf_counts"], handle["extras/rdf_samples"]
    with pytest.raises(RunFileError, match=r"accumulators \[\], this scene needs \['rdf_counts'"):
        resume(path, progress=False)
