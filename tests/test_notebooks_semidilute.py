"""Execute notebooks/semidilute_chains.ipynb in quick mode (JAXDPD_QUICK=1)."""

import pytest
from notebook_runner import run_quick_mode


@pytest.mark.slow
def test_semidilute_chains_notebook_quick_mode(monkeypatch):
    """Runs every cell without error: chains with spring repulsion in θ- and good
    solvent, then phantom springs for the spring pair distribution.  Marked slow: its
    three scenes (spring-pair lists included) each compile separately, about 2 minutes
    in all on 2 loaded cores."""
    outputs, elapsed = run_quick_mode("semidilute_chains.ipynb", monkeypatch, timeout=600)
    print(f"notebook quick mode: {elapsed:.1f} s")
    assert "quick mode" in outputs
    assert "θ-solvent" in outputs and "good solvent" in outputs
    assert "measured c/c*" in outputs
    assert "no repulsion" in outputs and "crossings/step" in outputs
