"""Execute notebooks/planar_elongation.ipynb in quick mode (JAXDPD_QUICK=1).

Marked slow: it takes 32 s alone on 2 cores (five compiled programs: diffusion,
dumbbell sweep, Brownian dynamics, stretch-and-relax, chain sweep), above the 30 s a
default-run test may add."""

import pytest
from notebook_runner import run_quick_mode


@pytest.mark.slow
def test_planar_elongation_notebook_quick_mode(monkeypatch):
    """Runs every cell without error: the drag coefficient from self-diffusion, the
    dumbbell sweep, the Brownian-dynamics reference, stretch-and-relax of chains with
    the eq. 5.15 fit, and the chain sweep; the stability limit is printed."""
    outputs, elapsed = run_quick_mode("planar_elongation.ipynb", monkeypatch, timeout=600)
    print(f"notebook quick mode: {elapsed:.1f} s")
    assert "quick mode" in outputs
    assert "drag coefficient (Einstein): ζ =" in outputs
    assert "stability limit ε̇ < ν(2π/L_y)²" in outputs
    assert "eq. 5.15: λ0 =" in outputs
    assert "<|R_e|>/L_c" in outputs
