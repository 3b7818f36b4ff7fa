"""Execute notebooks/fene_dumbbell_rheology.ipynb in quick mode (JAXDPD_QUICK=1)."""

import os

from notebook_runner import run_quick_mode


def test_fene_dumbbell_notebook_quick_mode(monkeypatch):
    """Runs every cell without error; the quick mode is meant to take < 60 s (kernel
    start and compilation included, measured on 2 idle cores)."""
    outputs, elapsed = run_quick_mode("fene_dumbbell_rheology.ipynb", monkeypatch)
    assert "quick mode" in outputs
    assert "state points" in outputs and "fit in" in outputs and "b = " in outputs
    print(f"notebook quick mode: {elapsed:.1f} s")
    assert os.environ["JAXDPD_QUICK"] == "1"
