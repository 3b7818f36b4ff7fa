"""Temperature sanity (issue 28, item 7): a run whose mean k_BT is off the set value
is flagged in the summary, printed and marked in the file (jaxdpd.analysis.temperature_check).

Reference: Groot–Warren's integrator holds k_BT within 1 % of the set point at
Δt = 0.04 and heats the fluid at larger steps (thesis §2.2.1; Groot & Warren, J.
Chem. Phys. 107, 4423 (1997)); at Δt = 0.1 this fluid measures k_BT ≈ 1.2–1.3.
"""

import io
import math

import h5py
import numpy as np
import pytest
from conftest import make_scene
from mpcd_scenes import pure_solvent

from jaxdpd.analysis.temperature_check import flag_points, is_off, temperature_warning
from jaxdpd.run.runner import RunSummary, simulate
from jaxdpd.scene import Scene


@pytest.mark.parametrize(
    ("mean", "error", "off"),
    [
        (1.02, 0.001, False),  # 20 σ but within 3 %
        (1.05, 0.001, True),
        (0.95, 0.001, True),  # too cold counts as well
        (1.05, 0.02, False),  # 5 % but only 2.5 σ
        (1.05, math.nan, True),  # no error estimate: 3 % alone decides
        (math.nan, 0.1, True),
        (math.inf, math.nan, True),
    ],
)
def test_is_off_needs_three_percent_and_three_standard_errors(mean, error, off):
    assert is_off(mean, error, 1.0) is off


def test_warning_names_the_departure_and_the_fix_of_each_solvent():
    dpd = make_scene(solvent={"kT": 2.0})
    message = temperature_warning(dpd, 2.5, 0.01)
    assert "k_BT = 2.5" in message and "solvent.kT = 2" in message and "+25.0%" in message
    assert "integrator.dt" in message and "lowe_andersen" in message
    assert temperature_warning(dpd, 2.02, 0.01) is None
    mpcd = Scene.from_dict(pure_solvent(5.0, 130.0, 0.1, 4.0))
    assert "solvent.thermostat" in temperature_warning(mpcd, 1.2, 0.01)


def test_flag_points_of_a_sweep():
    rng = np.random.default_rng(3)
    noise = rng.normal(0.0, 0.05, (3, 4000))
    temperature = np.array([[1.0], [1.1], [1.02]]) + noise
    np.testing.assert_array_equal(flag_points(temperature, 1.0), [False, True, False])
    with pytest.raises(ValueError, match="replicas, steps"):
        flag_points(temperature[0], 1.0)


def test_summary_table_marks_the_flagged_row():
    summary = RunSummary(
        None, 10, 1.0, averages={"temperature": (1.3, 0.01), "pressure": (23.0, 0.1)}
    )
    summary.warnings = {"temperature": "temperature: measured k_BT = 1.3"}
    lines = summary.table().splitlines()
    assert lines[1].startswith("temperature") and lines[1].endswith("<- WARNING")
    assert not lines[2].endswith("<- WARNING")
    assert lines[-1] == "WARNING: temperature: measured k_BT = 1.3"


@pytest.mark.slow  # two short runs, about a minute each on 2 busy cores
def test_hot_run_is_flagged_everywhere_and_a_good_run_nowhere(tmp_path):
    # Groot–Warren's λ = 0.65 holds k_BT within 0.1 % at Δt = 0.04
    # (benchmarks/results/timestep_accuracy.json); at Δt = 0.1 it measures ≈ 1.3.
    for dt, hot in ((0.1, True), (0.04, False)):
        path = tmp_path / f"dt{dt}.h5"
        scene = make_scene(
            particles={"count": 300},
            integrator={"dt": dt, "lambda": 0.65},
            run={"steps": 200, "chunk": 100, "equilibration": 300},
            output={"observables": ["temperature"]},
        )
        stream = io.StringIO()
        summary = simulate(scene, output_path=path, progress=False, stream=stream)
        mean, error = summary.averages["temperature"]
        assert ("temperature" in summary.warnings) is hot, (dt, mean, error)
        assert ("WARNING: temperature" in stream.getvalue()) is hot
        assert ("<- WARNING" in summary.table()) is hot
        with h5py.File(path) as handle:
            stored = handle["observables/temperature"].attrs.get("warning")
        assert (stored == summary.warnings.get("temperature")) if hot else stored is None
