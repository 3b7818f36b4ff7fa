"""H5MD output layout, the scene stored in it, and the command line."""

import h5py
import numpy as np
from conftest import make_scene

from jaxdpd.cli import demo_scene, main
from jaxdpd.io.h5md import read_observable, read_scene
from jaxdpd.runner import simulate


def test_h5md_file_holds_layout_scene_observables_and_frames(tmp_path):
    scene = make_scene(
        run={"steps": 60, "chunk": 20, "equilibration": 20},
        output={
            "observables": ["temperature", "pressure", "rdf"],
            "rdf_max": 2.5,
            "trajectory_every": 20,
        },
    )
    path = tmp_path / "run.h5"
    summary = simulate(scene, output_path=path, progress=False)
    with h5py.File(path, "r") as handle:
        assert list(handle["h5md"].attrs["version"]) == [1, 1]
        np.testing.assert_allclose(handle["particles/all/box/edges"][()], scene.box.lengths)
        positions = handle["particles/all/position/value"]
        assert positions.shape == (3, scene.n_particles, 3)
        assert list(handle["particles/all/position/step"][()]) == [40, 60, 80]
        assert handle["observables/rdf/g"].shape == (scene.output.rdf_bins,)
    assert read_scene(path) == scene
    steps, times, temperature = read_observable(path, "temperature")
    assert list(steps) == list(range(21, 81))
    np.testing.assert_allclose(times, steps * scene.integrator.dt)
    np.testing.assert_allclose(temperature, summary.series["temperature"])
    _, _, tensor = read_observable(path, "pressure_tensor")
    assert tensor.shape == (60, 3, 3)


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
    assert output.exists()


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
