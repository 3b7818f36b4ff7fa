"""Execute notebooks/mpcd_zimm.ipynb in quick mode (JAXDPD_QUICK=1).

About 13 s alone on 2 cores (kernel start and three compiled programs: two chain
lengths and the free monomers).  The quick mode checks that the notebook runs end to
end, not the physics: its runs are far too short to mean anything; the full-mode
outputs stored in the notebook are the result."""

from notebook_runner import run_quick_mode


def test_mpcd_zimm_notebook_quick_mode(monkeypatch):
    """Runs every cell without error: Gaussian chains of two lengths and free monomers
    in an SRD solvent, the ideal-chain statics, Rouse-mode correlation times against
    the Rouse and Zimm forms with a Rouse–Zimm fit, the centre-of-mass VACF tail, and
    D, D_0, R_H with the Kirkwood formula including periodic images."""
    outputs, elapsed = run_quick_mode("mpcd_zimm.ipynb", monkeypatch, timeout=600)
    print(f"notebook quick mode: {elapsed:.1f} s")
    assert "quick mode" in outputs
    assert "(ideal 0.800)" in outputs  # R_g² of N_m = 5
    assert "Rouse–Zimm fit of C(t): h* =" in outputs
    assert "Rouse   Zimm eq.19   Zimm diag.(h*)" in outputs
    assert "tail exponent" in outputs
    assert "D_0∞ =" in outputs
    assert "Kirkwood with images" in outputs
    assert "D_H ∝ R_H^ν" in outputs
