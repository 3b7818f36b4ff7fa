"""Execute notebooks/lb_single_chain.ipynb in quick mode (JAXDPD_QUICK=1)."""

import time
from pathlib import Path

import nbformat
import pytest
from nbclient import NotebookClient

NOTEBOOK = Path(__file__).resolve().parents[1] / "notebooks" / "lb_single_chain.ipynb"


@pytest.mark.slow
def test_lb_single_chain_notebook_quick_mode(monkeypatch):
    """Runs every cell without error (a Kremer–Grest chain in the LB solvent end to end:
    friction calibration by the lattice theory, replicas, statics, S(q), D_CM and eq.
    31); slow because its compilation alone takes ~30 s on 2 cores."""
    monkeypatch.setenv("JAXDPD_QUICK", "1")
    monkeypatch.setenv("MPLBACKEND", "Agg")
    nb = nbformat.read(NOTEBOOK, as_version=4)
    resources = {"metadata": {"path": str(NOTEBOOK.parent)}}
    client = NotebookClient(nb, timeout=600, kernel_name="python3", resources=resources)
    start = time.perf_counter()
    client.execute()
    outputs = "".join(
        out.get("text", "") for cell in nb.cells if cell.cell_type == "code" for out in cell.outputs
    )
    assert "quick mode" in outputs
    assert "gives D0 = 0.0760" in outputs
    assert "Table I" in outputs and "D_0 (eq. 31)" in outputs
    print(f"notebook quick mode: {time.perf_counter() - start:.1f} s")
