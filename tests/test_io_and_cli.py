"""H5MD output layout, the scene stored in it, and the command line."""

import os
import signal
import subprocess
import sys
import textwrap
from pathlib import Path

import h5py
import numpy as np
import pytest
from io_runs import (
    lees_edwards_edges,
    polymer_reference_run,
    reference_run,
)

from jaxdpd.analysis.statistics import block_average
from jaxdpd.io import load, read_checkpoint, read_observable, read_scene, read_trajectory
from jaxdpd.run import cli
from jaxdpd.run.cli import demo_scene, main


def test_h5md_file_holds_the_h5md_1_1_layout_scene_series_frames_and_checkpoint():
    """Layout of H5MD 1.1 (nongnu.org/h5md, "H5MD root level", "Particles group",
    "Simulation box"): metadata, box with step/time hard-linked to position's, image
    likewise, species, observables with step and time = step × dt; the checkpoint in
    its own file."""
    reference = reference_run()
    scene, path = reference.scene, reference.path
    steps, every = scene.run.steps, scene.output.trajectory_every
    with h5py.File(path, "r") as handle:
        assert list(handle["h5md"].attrs["version"]) == [1, 1]
        assert handle["h5md/creator"].attrs["name"] == "jaxdpd"
        assert "name" in handle["h5md/author"].attrs
        assert "r_c = m = k_BT = 1" in handle["parameters"].attrs["units"]
        particles = handle["particles/trajectory"]
        assert particles["box"].attrs["dimension"] == 3
        assert [b.decode() for b in particles["box"].attrs["boundary"]] == ["periodic"] * 3
        position = particles["position"]
        frames = list(range(every, steps + 1, every))
        assert list(position["step"][()]) == frames
        np.testing.assert_array_equal(position["time"][()], np.array(frames) * scene.integrator.dt)
        assert position["value"].shape == (len(frames), scene.n_particles, 3)
        for element in ("velocity", "image", "box/edges"):
            assert particles[f"{element}/step"] == position["step"]  # one object: hard link
            assert particles[f"{element}/time"] == position["time"]
        # Lees–Edwards shear: triclinic edges whose a2 carries the offset; the run
        # sums Δ step by step, the formula at once: equal to round-off (1e-12).
        edges = particles["box/edges/value"][()]
        expected = [lees_edwards_edges(scene, step) for step in frames]
        np.testing.assert_allclose(edges, expected, rtol=0, atol=1e-12)
        assert particles["image/value"].dtype == np.int32
        species = particles["species"]
        assert h5py.check_enum_dtype(species.dtype) == {"solvent": 0}
        assert species.shape == (scene.n_particles,)
        temperature = handle["observables/temperature"]
        assert temperature["value"].fletcher32
        assert temperature["time"].attrs["reduced_unit"] == "τ"
        assert handle["observables/pressure_tensor/value"].shape == (steps, 3, 3)
    assert read_scene(path) == scene
    checkpoint = read_checkpoint(path)  # beside the file: run.h5.checkpoint
    assert (checkpoint["reason"], checkpoint["step"]) == ("end of run", steps)
    series = read_observable(path, "temperature")
    np.testing.assert_array_equal(series.step, np.arange(1, steps + 1))
    np.testing.assert_array_equal(series.time, series.step * scene.integrator.dt)
    final = read_trajectory(path, "position").value[-1]
    np.testing.assert_array_equal(final, reference.summary.state.positions)


def test_polymer_runs_store_bonds_and_run_averages():
    """/connectivity/bonds (H5MD 1.1 "Connectivity group"), g(r) and the on-device
    time correlations under /averages."""
    reference = polymer_reference_run()
    scene = reference.scene
    with h5py.File(reference.path, "r") as handle:
        bonds = handle["connectivity/bonds"]
        assert handle[bonds.attrs["particles_group"]].name == "/particles/trajectory"
        np.testing.assert_array_equal(bonds[:3], [[0, 1], [2, 3], [4, 5]])
        assert handle["averages/rdf/g"].shape == (scene.output.rdf_bins,)
        assert handle["averages/rdf"].attrs["samples"] == scene.run.steps // scene.run.chunk
        for name in ("g1", "g2", "g3", "end_to_end_acf", "positional_acf"):
            correlation = handle[f"averages/dumbbell/{name}"]
            assert correlation["lag_time"].shape == correlation["value"].shape
    assert "dumbbell/D_CM" in reference.summary.averages


def test_load_gives_back_scene_checkpoint_and_every_observable():
    reference = reference_run()
    record = load(reference.path)
    assert record.scene == reference.scene
    assert (record.checkpoint.step, record.checkpoint.phase) == (2400, "production")
    parts = [f"pressure_tensor_part/{p}" for p in ("kinetic", "conservative", "dissipative")]
    expected = ["temperature", *parts, "pressure_tensor_part/random", "pressure_tensor"]
    assert list(record.observables) == [*expected, "pressure"]  # in the order written
    assert record.observables["pressure_tensor"].value.shape == (2400, 3, 3)


READ_WITHOUT_THE_ENGINE = textwrap.dedent(
    """
    import sys
    import jax
    compiled = []
    jax.monitoring.register_event_duration_secs_listener(
        lambda name, *_, **__: compiled.append(name) if "/compile/" in name else None
    )
    import jaxdpd.io
    engine = sorted(m for m in sys.modules if m.startswith("jaxdpd.engine"))
    assert not engine, f"import jaxdpd.io imported {engine}"
    # Importing the observables' unit tables imports jax_md, whose own import runs
    # (and compiles) a few jnp operations; reading must add nothing to them.
    compiled.clear()
    path = sys.argv[1]
    assert jaxdpd.io.read_observables(path)
    jaxdpd.io.read_trajectory(path)
    jaxdpd.io.read_checkpoint(path)
    assert not compiled, f"reading the series compiled: {compiled}"
    record = jaxdpd.io.load(path)
    assert record.checkpoint is not None and record.observables
    assert "jaxdpd.engine.build" not in sys.modules, "reading built a simulation"
    assert not compiled, f"reading the scene compiled: {compiled}"
    """
)


def test_reading_a_file_neither_imports_the_engine_nor_compiles_anything():
    """A fresh process: `import jaxdpd.io` imports no jaxdpd.engine module; reading a
    file's observables, frames, raw checkpoint and scene compiles nothing (JAX reports
    no compilation event after the import) and never imports the simulation builder."""
    path = reference_run().path
    root = str(Path(__file__).parent.parent)
    environment = {
        **os.environ,
        "PYTHONPATH": os.pathsep.join([root, os.environ.get("PYTHONPATH", "")]),
    }
    result = subprocess.run(
        [sys.executable, "-c", READ_WITHOUT_THE_ENGINE, str(path)],
        env=environment,
        capture_output=True,
        text=True,
        timeout=600,
    )
    assert result.returncode == 0, result.stderr[-3000:]


def test_streamed_block_averages_equal_those_of_the_stored_series():
    """The summary's running block sums (jaxdpd.analysis.running_averages) against
    statistics.block_average of the whole series read back from the file: same
    blocks, float64 sums in another order, so equal to round-off (1e-12 relative)."""
    reference = reference_run()
    averages = reference.summary.averages
    for name, label in (("temperature", "temperature"), ("pressure", "pressure")):
        mean, error = block_average(read_observable(reference.path, name).value, 20)
        np.testing.assert_allclose(averages[label], (mean, error), rtol=1e-12)
    tensor = read_observable(reference.path, "pressure_tensor").value
    mean, error = block_average(tensor[:, 0, 1], 20)
    np.testing.assert_allclose(averages["P_xy"], (mean, error), rtol=1e-12)


def test_cli_run_writes_output_and_prints_a_summary(tmp_path, capsys):
    scene_file = tmp_path / "scene.toml"
    scene_file.write_text(
        """
seed = 3
precision = "float32"
[particles]
density = 3.0
count = 500
[solvent]
method = "dpd"
gamma = 4.5
[pair]
a = 25.0
[run]
steps = 60
chunk = 30
"""
    )
    output = tmp_path / "out.h5"
    assert main(["run", str(scene_file), "-o", str(output), "-q"]) == 0
    printed = capsys.readouterr().out
    assert "temperature" in printed and "pressure" in printed and "particle-steps/s" in printed
    with h5py.File(output, "r") as handle:  # no frames: the box is a fixed element
        edges = handle["particles/trajectory/box/edges"][()]
    np.testing.assert_allclose(edges, [(500 / 3.0) ** (1 / 3)] * 3, rtol=1e-15)


def test_cli_refuses_an_invalid_scene_with_the_field_named(tmp_path, capsys):
    scene_file = tmp_path / "bad.toml"
    scene_file.write_text('[particles]\ndensity = -1.0\ncount = 10\n[solvent]\nmethod = "dpd"\n')
    assert main(["run", str(scene_file)]) == 2
    assert "particles.density" in capsys.readouterr().err


def test_demo_scene_is_valid_and_small_enough_for_two_minutes():
    scene = demo_scene()
    assert scene.solvent.method == "dpd"
    # ≈ 2e5 particle-steps/s on 2 cores (benchmarks/dpd_throughput.py): ~35 s of
    # stepping plus compilation stays well under two minutes.
    assert scene.n_particles * (scene.run.steps + scene.run.equilibration) <= 8e6


def test_ctrl_c_before_the_first_chunk_exits_130_without_a_traceback(tmp_path, capsys, monkeypatch):
    """SIGINT while the scene is built and compiled (before SignalGuard is active)
    raises KeyboardInterrupt: one line on stderr and status 130.  Started with SIGINT
    ignored (a background job), jaxdpd listens to it all the same, and puts the
    ignored disposition back on return."""
    during = []

    def interrupted(*args, **kwargs):
        during.append(signal.getsignal(signal.SIGINT))
        raise KeyboardInterrupt

    monkeypatch.setattr(cli, "prepare", interrupted)
    previous = signal.signal(signal.SIGINT, signal.SIG_IGN)
    try:
        assert main(["demo", "-o", str(tmp_path / "demo.h5")]) == 130
        assert signal.getsignal(signal.SIGINT) is signal.SIG_IGN
    finally:
        signal.signal(signal.SIGINT, previous)
    assert during == [signal.default_int_handler]
    error = capsys.readouterr().err.strip()
    assert error == (
        "jaxdpd: interrupted by SIGINT before the first chunk or after the last "
        "(no checkpoint written for it)"
    )


def test_a_negative_step_count_names_the_option(capsys):
    """--steps is checked as the option the user typed, not as the scene field."""
    with pytest.raises(SystemExit) as raised:
        main(["run", "scene.toml", "--steps", "-5"])
    assert raised.value.code == 2
    assert "--steps" in capsys.readouterr().err
