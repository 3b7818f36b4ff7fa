"""Execute notebooks/shear_flow_curve.ipynb in quick mode (JAXDPD_QUICK=1)."""

from quick_notebook import execute_quick


def test_shear_flow_curve_notebook_quick_mode(monkeypatch):
    """Runs every cell without error: two DPD ensemble sweeps and a Brownian-dynamics
    flow curve (about 40 s of CPU time, mostly compilation)."""
    outputs = execute_quick("shear_flow_curve.ipynb", monkeypatch, timeout=600)
    assert "quick mode" in outputs
    assert "drag coefficient (tagged particles at rest): ζ =" in outputs
    assert "state points" in outputs and "λ_H = ζ/4H" in outputs
    assert "spring + bead repulsion" in outputs
