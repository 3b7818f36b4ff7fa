"""Execute notebooks/fene_dumbbell_rheology.ipynb in quick mode (JAXDPD_QUICK=1)."""

from quick_notebook import execute_quick


def test_fene_dumbbell_notebook_quick_mode(monkeypatch):
    """Runs every cell without error; the quick mode is meant to take < 60 s (kernel
    start and compilation included, measured on 2 idle cores)."""
    outputs = execute_quick("fene_dumbbell_rheology.ipynb", monkeypatch)
    assert "quick mode" in outputs
    assert "state points" in outputs and "fit in" in outputs and "b = " in outputs
