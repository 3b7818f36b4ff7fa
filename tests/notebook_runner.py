"""Execute a notebook of notebooks/ in its quick mode (JAXDPD_QUICK=1)."""

import time
from pathlib import Path

import nbformat
from nbclient import NotebookClient

NOTEBOOKS = Path(__file__).resolve().parents[1] / "notebooks"


def run_quick_mode(name: str, monkeypatch, timeout: int = 300) -> tuple[str, float]:
    """Run every cell of notebooks/<name> with JAXDPD_QUICK=1 and the Agg backend.

    Returns:
        (the text of all code-cell outputs, seconds taken).
    """
    monkeypatch.setenv("JAXDPD_QUICK", "1")
    monkeypatch.setenv("MPLBACKEND", "Agg")
    path = NOTEBOOKS / name
    nb = nbformat.read(path, as_version=4)
    resources = {"metadata": {"path": str(path.parent)}}
    client = NotebookClient(nb, timeout=timeout, kernel_name="python3", resources=resources)
    start = time.perf_counter()
    client.execute()
    outputs = "".join(
        out.get("text", "") for cell in nb.cells if cell.cell_type == "code" for out in cell.outputs
    )
    return outputs, time.perf_counter() - start
