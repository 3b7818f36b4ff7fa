"""Execute notebooks/lb_single_chain.ipynb in quick mode (JAXDPD_QUICK=1)."""

import pytest
from notebook_runner import run_quick_mode


@pytest.mark.slow
def test_lb_single_chain_notebook_quick_mode(monkeypatch):
    """Runs every cell without error: a Kremer–Grest chain in the LB solvent end to end
    (friction calibrated by the lattice theory, replicas, statics, S(q), D_CM and
    eq. 31).  Marked slow: its compilation alone takes ~30 s on 2 cores."""
    outputs, elapsed = run_quick_mode("lb_single_chain.ipynb", monkeypatch, timeout=600)
    assert "quick mode" in outputs
    assert "gives D0 = 0.0760" in outputs
    assert "Table I" in outputs and "D_0 (eq. 31)" in outputs
    print(f"notebook quick mode: {elapsed:.1f} s")
