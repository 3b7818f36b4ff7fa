"""Execute a notebook of notebooks/ in quick mode (JAXDPD_QUICK=1) for the tests."""

import os
import time
from pathlib import Path

import nbformat
from nbclient import NotebookClient

NOTEBOOKS = Path(__file__).resolve().parents[1] / "notebooks"


def execute_quick(name: str, monkeypatch, timeout: int = 300) -> str:
    """Run every cell of notebooks/<name> with JAXDPD_QUICK=1 and a non-interactive
    matplotlib backend; return the text the code cells printed."""
    monkeypatch.setenv("JAXDPD_QUICK", "1")
    monkeypatch.setenv("MPLBACKEND", "Agg")
    path = NOTEBOOKS / name
    nb = nbformat.read(path, as_version=4)
    resources = {"metadata": {"path": str(NOTEBOOKS)}}
    client = NotebookClient(nb, timeout=timeout, kernel_name="python3", resources=resources)
    start = time.perf_counter()
    client.execute()
    print(f"{name} quick mode: {time.perf_counter() - start:.1f} s")
    assert os.environ["JAXDPD_QUICK"] == "1"
    return "".join(
        out.get("text", "") for cell in nb.cells if cell.cell_type == "code" for out in cell.outputs
    )
