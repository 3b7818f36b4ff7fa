"""A user's toolkit: `jaxdpd summary` and `jaxdpd plot` of a run file, the blocking
verdict on series whose answer is known, the /averages reader, the top-level API,
the command line's comforts (--version, a cheap import, did-you-mean) and the progress
lines of a redirected log."""

import io
import os
import subprocess
import sys

import numpy as np
import pytest
from ar1_series import ar1, ar1_block_error
from conftest import make_scene
from io_runs import polymer_reference_run, polymer_scene

import jaxdpd
from jaxdpd.analysis.file_summary import read_summary, verdict
from jaxdpd.analysis.statistics import blocking_plateau
from jaxdpd.io import Correlation, RadialDistribution, read_averages
from jaxdpd.io.h5md import H5MDWriter
from jaxdpd.run import cli
from jaxdpd.run.cli import main
from jaxdpd.run.progress import Progress
from jaxdpd.validation import SceneError


def test_blocking_plateau_of_a_correlated_series_gives_its_exact_error():
    """AR(1), φ = 0.9 (τ_int = g/2 = 9.5 steps), 2^16 samples: the plateau is reached,
    and its standard error equals the exact one within 3 of its own relative
    uncertainty 1/sqrt(2 (n_b − 1)) (Flyvbjerg & Petersen 1989, eq. 28)."""
    phi, samples = 0.9, 2**16
    block, error = blocking_plateau(ar1(phi, samples, seed=1))
    assert block is not None
    blocks = samples // block
    exact = ar1_block_error(phi, samples, block)
    assert abs(error / exact - 1) < 3 / np.sqrt(2 * (blocks - 1)), (block, error, exact)


def test_blocking_plateau_is_not_reached_when_the_series_is_too_short():
    """AR(1), φ = 0.999 (τ_int ≈ 1000 steps) over 2048 samples: the longest blocks
    (256 samples) are far shorter than the correlation time, so no plateau; the
    verdict says so, whatever the table's block length."""
    series = ar1(0.999, 2048, seed=2)
    block, error = blocking_plateau(series)
    assert block is None
    # The longest blocks' error underestimates the exact standard error of the mean.
    assert error < ar1_block_error(0.999, 2048, 2048)
    check = verdict(series, block_length=102)
    assert not check.trusted and "NO PLATEAU" in check.note()


def synthetic_run(path, temperature, pressure):
    """A run file written by H5MDWriter with the given per-step series (no engine)."""
    scene = make_scene(run={"steps": len(temperature), "chunk": 64})
    with H5MDWriter.create(path, scene) as writer:
        tensor = np.zeros((len(pressure), 3, 3)) + np.eye(3) * pressure[:, None, None]
        writer.append_observables(
            0, {"temperature": temperature, "pressure": pressure, "pressure_tensor": tensor}
        )
    return scene


def test_summary_of_a_file_gives_units_and_a_plain_verdict(tmp_path, capsys):
    """Series with known correlation: a temperature with τ_int ≈ 1000 steps over 2048
    steps (no plateau: said plainly), a pressure with τ_int = 1.5 steps (plateau well
    below the table's blocks of 102 steps: trusted)."""
    path = tmp_path / "synthetic.h5"
    samples = 2048
    synthetic_run(
        path, ar1(0.999, samples, 3, 1.0, scale=0.001), ar1(0.5, samples, 4, 23.7, scale=0.1)
    )
    summary = read_summary(path)
    assert summary.averages.block_length == samples // 20
    assert summary.checks["temperature"].plateau is None
    assert summary.checks["pressure"].trusted
    assert main(["summary", str(path)]) == 0
    text = capsys.readouterr().out
    rows = {line.split()[0]: line for line in text.splitlines() if line[:1].strip()}
    assert "k_BT" in rows["temperature"].split() and "NO PLATEAU" in rows["temperature"]
    assert "k_BT/r_c^3" in rows["pressure"].split() and "ok (plateau" in rows["pressure"]
    assert "No blocking plateau was reached for temperature" in text
    assert "glossary" in text and "P_xy" in text


def test_summary_reproduces_the_run_and_plot_writes_every_figure(tmp_path, capsys):
    """A short run of dumbbells with every observable at rest: `jaxdpd summary` gives
    the rows the run printed (the same block averages, read back), and `jaxdpd plot`
    writes one non-empty figure per kind of data the file holds."""
    pytest.importorskip("matplotlib")
    reference = polymer_reference_run()
    summary = read_summary(reference.path)
    assert summary.rows.keys() == reference.summary.averages.keys()
    for name, (mean, error) in reference.summary.averages.items():
        np.testing.assert_allclose(summary.rows[name], (mean, error), rtol=1e-9, err_msg=name)
    averages = read_averages(reference.path)
    assert isinstance(averages["rdf"], RadialDistribution) and averages["rdf"].samples > 0
    g3 = averages["dumbbell/g3"]
    assert isinstance(g3, Correlation) and g3.per_element.shape[:2] == (len(g3.lag_time), 24)
    directory = tmp_path / "figures"
    assert main(["plot", str(reference.path), "-o", str(directory), "--format", "png"]) == 0
    kinds = ("thermo", "stress", "rdf", "msd", "correlations", "conformation")
    figures = [directory / f"{reference.path.stem}_{kind}.png" for kind in kinds]
    assert capsys.readouterr().out.split() == [str(figure) for figure in figures]
    for figure in figures:
        assert figure.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n" and figure.stat().st_size > 10_000


def test_simulate_returns_the_state_and_every_step_of_the_observables():
    """jaxdpd.simulate(scene, steps): the state after `steps` steps and one row per step
    of each series (the same program as the runner's chunk: the compilation cache
    serves it)."""
    scene = polymer_scene()
    state, observables = jaxdpd.simulate(scene, 20)
    assert int(state.step) == 20
    assert observables["temperature"].shape == (20,)
    assert observables["pressure_tensor"].shape == (20, 3, 3)
    assert np.all(np.isfinite(observables["dumbbell/bond_length_sq"]))
    record = jaxdpd.load(polymer_reference_run().path)
    assert record.scene == scene and "rdf" in record.averages


def test_import_is_cheap_and_leaves_jax_alone():
    """`import jaxdpd` loads no JAX (so cannot switch on 64-bit types); the top-level
    names load their modules on first use; --version answers without JAX."""
    code = (
        "import sys, jaxdpd; assert 'jax' not in sys.modules; "
        "from jaxdpd.run import cli; assert 'jax' not in sys.modules; "
        "scene = jaxdpd.Scene; import jax; assert not jax.config.jax_enable_x64; "
        "assert callable(jaxdpd.build) and callable(jaxdpd.load) and callable(jaxdpd.simulate)"
    )
    environment = {k: v for k, v in os.environ.items() if k != "JAX_ENABLE_X64"}
    subprocess.run([sys.executable, "-c", code], check=True, env=environment)
    version = subprocess.run(
        [sys.executable, "-m", "jaxdpd.run.cli", "--version"],
        check=True,
        capture_output=True,
        text=True,
    )
    assert version.stdout.strip() == f"jaxdpd {jaxdpd.__version__}"


def test_an_unknown_key_names_the_likely_one():
    with pytest.raises(SceneError, match=r"solvent.*'gama' \(did you mean 'gamma'\?\)$"):
        make_scene(solvent={"gama": 4.5})
    with pytest.raises(SceneError, match=r"'integrater' \(did you mean 'integrator'\?\)"):
        make_scene(integrater={"dt": 0.01})
    # Nothing alike: the valid keys are listed.
    with pytest.raises(SceneError, match=r"'timestep'; valid keys: \['dt', 'lambda'\]"):
        make_scene(integrator={"timestep": 0.01})


def test_progress_in_a_log_is_plain_lines_with_temperature_and_pressure():
    stream = io.StringIO()  # not a terminal
    progress = Progress(100, stream, enabled=True)
    for done in range(10, 101, 10):
        progress.update(done, {"temperature": np.full(10, 1.02), "pressure": np.full(10, 23.7)})
    progress.finish()
    lines = stream.getvalue().splitlines()
    assert "\r" not in stream.getvalue() and len(lines) == 10
    assert lines[-1].startswith("[jaxdpd] 100/100 steps, T = 1.02, P = 23.7")


class _Terminal(io.StringIO):
    def isatty(self):
        return True


def test_progress_on_a_terminal_is_a_tqdm_bar_started_after_the_first_chunk():
    """The bar appears at the first chunk's end (its rate leaves out compilation) and
    shows the latest chunk's T and P."""
    stream = _Terminal()
    progress = Progress(100, stream, enabled=True)
    progress.update(10, {"temperature": np.full(10, 1.5)})
    assert progress.bar is not None and progress.bar.initial == 10
    progress.update(20, {"temperature": np.full(10, 1.02), "pressure": np.full(10, 23.7)})
    progress.finish()
    assert "20/100" in stream.getvalue() and "T=1.02, P=23.7" in stream.getvalue()


def test_demo_without_output_says_where_it_writes(tmp_path, monkeypatch, capsys):
    """`jaxdpd demo` without -o writes demo.h5md in the current folder and says so
    before anything is built (here the build is cut short by a Ctrl-C)."""
    written = []

    def interrupted(scene, path, **options):
        written.append(path)
        raise KeyboardInterrupt

    monkeypatch.setattr(cli, "prepare", interrupted)
    monkeypatch.chdir(tmp_path)
    assert main(["demo"]) == 130
    assert written == ["demo.h5md"]
    assert "jaxdpd: writing demo.h5md (give -o FILE to write elsewhere)" in capsys.readouterr().err


def test_the_demo_is_a_groot_warren_fluid_at_lambda_0_65():
    """One species, no polymers, ρ = 3, a = 25, γ = 4.5, Δt = 0.04, λ = 0.65 (Groot &
    Warren 1997; λ = 0.5 overheats at this Δt, README time-step table)."""
    scene = cli.demo_scene()
    assert scene.polymers == () and len(scene.particles.species) == 1
    assert (scene.particles.density, scene.solvent.gamma, scene.solvent.kT) == (3.0, 4.5, 1.0)
    assert (scene.integrator.dt, scene.integrator.lambda_) == (0.04, 0.65)
