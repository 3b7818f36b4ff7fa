"""The flow rows of the run summary on stress series with known means: P_yy and the
normal stress differences of steady shear, the planar elongational viscosities of a
Kraynik–Reinelt run, each with its unit and glossary line in `jaxdpd summary`.

References: N1 = σ_xx − σ_yy, N2 = σ_yy − σ_zz with P = −σ (Bird, Armstrong &
Hassager vol. 1, 2nd ed. (1987), ch. 3; thesis eqs. 4.12–4.13); planar elongation
with z stretching and x compressing, η̄1 = (P_xx − P_zz)/ε̇, η̄2 = (P_xx − P_yy)/ε̇
(thesis eqs. 3.25–3.26, 5.12), which a Newtonian stress σ = 2η D, D = ε̇ diag(−1, 0, 1)
makes 4η and 2η.  Independent Gaussian noise of σ = NOISE per component gives a
difference of two components the exact standard error √2 σ/√T; tolerances are 4 of
those.
"""

import numpy as np
from conftest import scene_dict

from jaxdpd.analysis.file_summary import read_summary
from jaxdpd.io.h5md import H5MDWriter
from jaxdpd.run.cli import main
from jaxdpd.scene import Scene

SAMPLES, NOISE, SIGMAS = 4000, 0.5, 4.0
ERROR = np.sqrt(2) * NOISE / np.sqrt(SAMPLES)  # of a difference of two components


def stress_run(path, scene, mean):
    """A run file (H5MDWriter, no engine) whose pressure tensor is `mean` plus
    independent Gaussian noise of σ = NOISE, with a springs' part of 1/10 of it."""
    noise = np.random.default_rng(3).normal(0.0, NOISE, (SAMPLES, 3, 3))
    tensor = mean + noise
    with H5MDWriter.create(path, scene) as writer:
        writer.append_observables(
            0,
            {
                "pressure_tensor": tensor,
                "pressure": np.trace(tensor, axis1=1, axis2=2) / 3,
                "pressure_tensor_part/bond": tensor / 10,
            },
        )
    return read_summary(path)


def flow_scene(box: dict, flow: dict) -> Scene:
    """The tests' base scene at ρ = 3 in `box` under `flow`, SAMPLES steps long."""
    data = scene_dict(box=box, flow=flow, run={"steps": SAMPLES, "chunk": 100})
    data["particles"] = {"density": 3.0}
    return Scene.from_dict(data)


def summary_text(path, capsys) -> tuple[dict, dict]:
    """`jaxdpd summary PATH`: name → its table line, name → its glossary line."""
    assert main(["summary", str(path)]) == 0
    table, glossary = {}, {}
    for line in capsys.readouterr().out.splitlines():
        if line.strip():
            entries = glossary if line.startswith("  ") else table
            entries.setdefault(line.split()[0], line)
    return table, glossary


def assert_row(rows, name, exact, error):
    mean, _ = rows[name]
    assert abs(mean - exact) < SIGMAS * error, (name, mean, exact, error)


def test_shear_rows_give_p_yy_and_the_normal_stress_differences(tmp_path, capsys):
    rate, p_xx, p_yy, p_zz = 0.5, 3.2, 3.0, 3.1
    mean = np.diag([p_xx, p_yy, p_zz]) + np.array([[0, -0.3, 0], [-0.3, 0, 0], [0, 0, 0]])
    scene = flow_scene({"lengths": [8.0, 8.0, 8.0]}, {"kind": "shear", "shear_rate": rate})
    summary = stress_run(tmp_path / "shear.h5md", scene, mean)
    rows = summary.rows
    assert_row(rows, "P_yy", p_yy, NOISE / np.sqrt(SAMPLES))
    assert_row(rows, "N1", p_yy - p_xx, ERROR)
    assert_row(rows, "N2", p_zz - p_yy, ERROR)
    # Ψ1 = N1/γ̇², Ψ2 = N2/γ̇² of the same samples.
    np.testing.assert_allclose(rows["psi1"][0], rows["N1"][0] / rate**2, rtol=1e-12)
    np.testing.assert_allclose(rows["psi2"][0], rows["N2"][0] / rate**2, rtol=1e-12)
    table, glossary = summary_text(tmp_path / "shear.h5md", capsys)
    for name in ("P_yy", "N1", "N2"):
        assert "k_BT/r_c^3" in table[name].split() and name in glossary, name
    assert "σ_xx − σ_yy" in glossary["N1"]


def test_planar_elongation_rows_give_the_elongational_viscosities(tmp_path, capsys):
    """A Newtonian stress of η = 0.9 at ε̇ = 0.1 (z stretches): η̄1 = 4η, η̄2 = 2η;
    the springs' part (a tenth of the stress) gives polymer/eta1, polymer/eta2."""
    rate, eta, pressure = 0.1, 0.9, 23.7
    mean = pressure * np.eye(3) - 2 * eta * rate * np.diag([-1.0, 0.0, 1.0])
    flow = {"kind": "planar_elongation", "elongation_rate": rate}
    scene = flow_scene({"lengths": [8.0, 4.0, 8.0]}, flow)
    summary = stress_run(tmp_path / "elongation.h5md", scene, mean)
    rows = summary.rows
    assert_row(rows, "eta1", 4 * eta, ERROR / rate)
    assert_row(rows, "eta2", 2 * eta, ERROR / rate)
    assert_row(rows, "polymer/eta1", 0.4 * eta, ERROR / 10 / rate)
    assert_row(rows, "polymer/eta2", 0.2 * eta, ERROR / 10 / rate)
    assert "viscosity" not in rows and "N1" not in rows
    table, glossary = summary_text(tmp_path / "elongation.h5md", capsys)
    for name in ("eta1", "eta2", "polymer/eta1"):
        assert "k_BT τ/r_c^3" in table[name], name
    assert "η̄1 = (P_xx − P_zz)/ε̇" in glossary["eta1"]
