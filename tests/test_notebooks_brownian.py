"""Execute notebooks/fene_dumbbell_rheology.ipynb in quick mode (JAXDPD_QUICK=1)."""

import os
import time
from pathlib import Path

import nbformat
from nbclient import NotebookClient

NOTEBOOK = Path(__file__).resolve().parents[1] / "notebooks" / "fene_dumbbell_rheology.ipynb"


def test_fene_dumbbell_notebook_quick_mode(monkeypatch):
    """Runs every cell without error; the quick mode is meant to take < 60 s (kernel
    start and compilation included, measured on 2 idle cores)."""
    monkeypatch.setenv("JAXDPD_QUICK", "1")
    monkeypatch.setenv("MPLBACKEND", "Agg")
    nb = nbformat.read(NOTEBOOK, as_version=4)
    resources = {"metadata": {"path": str(NOTEBOOK.parent)}}
    client = NotebookClient(nb, timeout=300, kernel_name="python3", resources=resources)
    start = time.perf_counter()
    client.execute()
    elapsed = time.perf_counter() - start
    outputs = "".join(
        out.get("text", "") for cell in nb.cells if cell.cell_type == "code" for out in cell.outputs
    )
    assert "quick mode" in outputs
    assert "state points" in outputs and "fit in" in outputs and "b = " in outputs
    print(f"notebook quick mode: {elapsed:.1f} s")
    assert os.environ["JAXDPD_QUICK"] == "1"
