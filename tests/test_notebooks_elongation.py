"""Execute notebooks/planar_elongation.ipynb in quick mode (JAXDPD_QUICK=1)."""

from notebook_runner import run_quick_mode


def test_planar_elongation_notebook_quick_mode(monkeypatch):
    """Runs every cell without error: the drag measurement, the dumbbell sweep, the
    Brownian-dynamics reference, stretch-and-relax of chains and the chain sweep."""
    outputs, elapsed = run_quick_mode("planar_elongation.ipynb", monkeypatch, timeout=600)
    print(f"notebook quick mode: {elapsed:.1f} s")
    assert "quick mode" in outputs
    assert "drag coefficient (Einstein): ζ =" in outputs
    assert "stability limit ε̇ < ν(2π/L_y)²" in outputs
    assert "eq. 5.15: λ0 =" in outputs
    assert "<|R_e|>/L_c" in outputs
