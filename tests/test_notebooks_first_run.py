"""Execute notebooks/first_run.ipynb in quick mode (JAXDPD_QUICK=1)."""

import pytest
from notebook_runner import run_quick_mode


@pytest.mark.slow
def test_first_run_notebook_quick_mode(monkeypatch):
    """Runs every cell: a scene file is written and run, the H5MD file read back and
    plotted, and MDAnalysis opens its frames.  Marked slow: it compiles a 3000-particle
    DPD fluid (about 20 s on 2 cores) and MDAnalysis's g(r) adds more."""
    pytest.importorskip("MDAnalysis")
    outputs, elapsed = run_quick_mode("first_run.ipynb", monkeypatch, timeout=600)
    assert "quick mode" in outputs
    assert "3000 atoms, 2 frames" in outputs
    print(f"notebook quick mode: {elapsed:.1f} s")
