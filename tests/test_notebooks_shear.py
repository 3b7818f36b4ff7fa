"""Execute notebooks/shear_flow_curve.ipynb in quick mode (JAXDPD_QUICK=1)."""

import pytest
from notebook_runner import run_quick_mode


@pytest.mark.slow  # two DPD sweeps and a BD curve: about 70 s
def test_shear_flow_curve_notebook_quick_mode(monkeypatch):
    """Runs every cell without error: two DPD ensemble sweeps and a Brownian-dynamics
    flow curve (about 40 s, mostly compilation)."""
    outputs, elapsed = run_quick_mode("shear_flow_curve.ipynb", monkeypatch, timeout=600)
    print(f"notebook quick mode: {elapsed:.1f} s")
    assert "quick mode" in outputs
    assert "drag coefficient (tagged particles at rest): ζ =" in outputs
    assert "state points" in outputs and "λ_H = ζ/4H" in outputs
    assert "spring + bead repulsion" in outputs
