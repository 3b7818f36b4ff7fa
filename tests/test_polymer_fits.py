"""Fits recover known parameters from synthetic noisy data, with calibrated error bars.

Calibration: over R independent repeats the fitted values scatter with a standard
deviation s; the reported error sigma should equal s.  With R repeats s itself is
uncertain by about s/sqrt(2(R-1)); the checks allow the mean reported sigma to differ
from s by a factor 1.5 at most (the brief's criterion), and, for the fixed seed, the true
value to lie within 3 sigma of every single fit.
"""

import numpy as np
import pytest

from jaxdpd.analysis import fits

REPEATS = 200


def calibration(estimates, errors, truth):
    """(max |z| over repeats, mean reported error / scatter of the estimates)."""
    estimates, errors = np.asarray(estimates), np.asarray(errors)
    z = (estimates - truth) / errors
    return np.abs(z).max(), errors.mean() / estimates.std(ddof=1)


@pytest.mark.parametrize("given_errors", [True, False])
def test_power_law_fit_recovers_exponent_with_calibrated_error(given_errors):
    """y = A x^nu with 5 per cent log-normal noise (sigma_ln y = 0.05) on 12 log-spaced x.
    With given errors (0.05 y) the weighted fit's covariance is exact for linear least
    squares in log-log and z = (nu_hat - nu)/sigma is standard normal; without, sigma
    comes from the residual scatter and z follows Student's t with 10 degrees of freedom.
    The fraction of repeats with |z| < 1 (0.683, or 0.659 for t_10) is checked within 4
    binomial standard errors sqrt(c (1 - c)/R)."""
    amplitude, exponent = 2.5, 0.588
    rng = np.random.default_rng(17)
    x = np.geomspace(1, 100, 12)
    results = []
    for _ in range(REPEATS):
        y = amplitude * x**exponent * np.exp(0.05 * rng.normal(size=x.size))
        results.append(fits.fit_power_law(x, y, 0.05 * y if given_errors else None))
    assert results[0].degrees_of_freedom == 10
    for name, value in (("exponent", exponent), ("amplitude", amplitude)):
        estimates = np.array([r[name] for r in results])
        errors = np.array([r.error(name) for r in results])
        assert np.all(np.abs(estimates[:10] - value) < 3 * errors[:10])
        worst, ratio = calibration(estimates, errors, value)
        assert 1 / 1.5 < ratio < 1.5
        if given_errors:
            assert worst < 4  # P(|z| > 4) = 6e-5 per fit
    nu = np.array([r["exponent"] for r in results])
    nu_error = np.array([r.error("exponent") for r in results])
    if given_errors:
        expected = 0.6827
    else:
        grid = np.linspace(-200, 200, 400001)
        density = (1 + grid**2 / 10) ** -5.5
        expected = density[np.abs(grid) < 1].sum() / density.sum()
    coverage = np.mean(np.abs(nu - exponent) < nu_error)
    assert abs(coverage - expected) < 4 * np.sqrt(expected * (1 - expected) / REPEATS)


def test_end_to_end_relaxation_fit_recovers_relaxation_time():
    """Thesis eq. 5.15, <R_e^2>(t) = L_0^2 exp(-t/lambda_0) + L_e^2, with lambda_0 = 40,
    L_0^2 = 300, L_e^2 = 20 (N = 20-like numbers), 60 points on 0..200 with Gaussian noise
    of standard deviation 2 (given as the errors)."""
    truth = {"amplitude": 300.0, "relaxation_time": 40.0, "plateau": 20.0}
    rng = np.random.default_rng(5)
    t = np.linspace(0, 200, 60)
    clean = fits.exponential_relaxation(t, **truth)
    results = [
        fits.fit_end_to_end_relaxation(t, clean + 2 * rng.normal(size=t.size), 2.0)
        for _ in range(100)
    ]
    for name, value in truth.items():
        estimates = [r[name] for r in results]
        errors = [r.error(name) for r in results]
        assert all(abs(e - value) < 3 * s for e, s in zip(estimates[:10], errors[:10], strict=True))
        worst, ratio = calibration(estimates, errors, value)
        assert worst < 4 and 1 / 1.5 < ratio < 1.5, (name, worst, ratio)
    # Without errors the residual scatter sets the error; chi^2/dof is then 1 by construction.
    unweighted = fits.fit_end_to_end_relaxation(t, clean + 2 * rng.normal(size=t.size))
    assert abs(unweighted["relaxation_time"] - 40) < 3 * unweighted.error("relaxation_time")


def test_rouse_zimm_fit_recovers_tau_and_h_star():
    """C(t) of the Rouse-Zimm model (N = 20, tau_1 = 50, h* = 0.2) on 40 log-spaced times
    from 0.5 to 200, plus Gaussian noise 0.003 (given).  Both parameters are recovered
    within 3 sigma for the fixed seed and the errors are calibrated over 50 repeats."""
    n_beads, tau_1, h_star = 20, 50.0, 0.2
    t = np.geomspace(0.5, 200, 40)
    clean = fits.rouse_zimm_correlation(t, n_beads, tau_1, h_star)
    rng = np.random.default_rng(9)
    results = [
        fits.fit_rouse_zimm(t, clean + 0.003 * rng.normal(size=t.size), n_beads, error=0.003)
        for _ in range(50)
    ]
    for name, value in (("longest_relaxation_time", tau_1), ("h_star", h_star)):
        estimates = [r[name] for r in results]
        errors = [r.error(name) for r in results]
        assert all(abs(e - value) < 3 * s for e, s in zip(estimates[:10], errors[:10], strict=True))
        worst, ratio = calibration(estimates, errors, value)
        assert worst < 4 and 1 / 1.5 < ratio < 1.5, (name, worst, ratio)
    # h* is resolved: Rouse (h* = 0) is excluded by many standard errors.
    assert results[0]["h_star"] > 10 * results[0].error("h_star")


def test_rouse_zimm_model_limits_and_accuracy():
    """Relaxation times in units of zeta/H: h* = 0 gives the Rouse times
    1/(4 sin^2(p pi/2N)); N = 2 gives the preaveraged-HI dumbbell 1/(2(1 - sqrt(2) h*))
    (two beads: the connector relaxes with mobility (1 - zeta Omega_12)/zeta); and the
    diagonal approximation stays within 2 per cent of the exact Zimm relaxation times
    (inverse nonzero eigenvalues of H.A, Zimm, J. Chem. Phys. 24, 269 (1956)) for N = 20,
    h* <= 0.25, p <= 4 (measured: 1.4 per cent at most)."""
    n = 20
    p = np.arange(1, n)
    np.testing.assert_allclose(
        fits.zimm_relaxation_times(n, 0.0), 1 / (4 * np.sin(p * np.pi / (2 * n)) ** 2)
    )
    assert fits.zimm_relaxation_times(2, 0.3)[0] == pytest.approx(1 / (2 * (1 - np.sqrt(2) * 0.3)))
    assert fits.rouse_zimm_correlation(0.0, n, 7.0, 0.2) == pytest.approx(1.0)
    beads = np.arange(n)
    separation = np.abs(beads[:, None] - beads[None, :]).astype(float)
    rouse_matrix = 2 * np.eye(n) - np.eye(n, k=1) - np.eye(n, k=-1)
    rouse_matrix[0, 0] = rouse_matrix[-1, -1] = 1
    for h_star in (0.1, 0.25):
        oseen = np.eye(n) + np.where(
            separation > 0, np.sqrt(2) * h_star / np.sqrt(np.maximum(separation, 1)), 0
        )
        exact = 1 / np.sort(np.linalg.eigvals(oseen @ rouse_matrix).real)[1:5]
        np.testing.assert_allclose(fits.zimm_relaxation_times(n, h_star)[:4], exact, rtol=0.02)
    with pytest.raises(ValueError, match="h_star"):
        fits.zimm_relaxation_times(n, 0.6)


def test_bad_arguments():
    with pytest.raises(ValueError, match="positive"):
        fits.fit_power_law([1.0, 2.0, 3.0], [1.0, -1.0, 2.0])
    with pytest.raises(ValueError, match="equal length"):
        fits.fit_power_law([1.0, 2.0], [1.0, 2.0, 3.0])
    with pytest.raises(ValueError, match="at least 4"):
        fits.fit_end_to_end_relaxation([0.0, 1.0, 2.0], [3.0, 2.0, 1.0])
    with pytest.raises(ValueError, match="n_beads"):
        fits.fit_rouse_zimm([1.0, 2.0, 3.0], [0.9, 0.8, 0.7], n_beads=1)


def three_bead_zimm(t, tau_1, h_star):
    """Exact C(t) of the preaveraged Zimm model for N = 3, derived by hand: with
    D = [[1, a, b], [a, 1, a], [b, a, 1]] (a = sqrt(2) h*, b = h*) and the Rouse matrix
    A, the antisymmetric mode (1, 0, -1) is an eigenvector of D.A with eigenvalue
    1 - h*, and (1, -2, 1) is one modulo the centre of mass (which C ignores) with
    eigenvalue 3 - 4 sqrt(2) h* + h*.  The static weights sin^-2(p pi/6) normalised
    are 3/4 and 1/4."""
    ratio = (3 - 4 * np.sqrt(2) * h_star + h_star) / (1 - h_star)
    return 0.75 * np.exp(-t / tau_1) + 0.25 * np.exp(-ratio * t / tau_1)


def rouse_chain(t, n_beads, tau_1):
    """Exact C(t) of the discrete Rouse chain: weights sin^-2(p pi/2N) normalised, rates
    sin^2(p pi/2N)/sin^2(pi/2N) / tau_1 (Doi & Edwards 1986, sec. 4.1)."""
    sin2 = np.sin(np.arange(1, n_beads) * np.pi / (2 * n_beads)) ** 2
    weights = (1 / sin2) / np.sum(1 / sin2)
    return np.exp(-np.outer(t, sin2 / sin2[0]) / tau_1) @ weights


def test_rouse_zimm_fit_of_exact_curves_inside_and_at_the_bounds_and_a_dumbbell():
    """Exact curves (no noise) give back their parameters to the optimiser's
    convergence (relative 1e-6): N = 3 Zimm with h* = 0.15; a 12-bead Rouse chain, whose
    h* = 0 is the lower bound; N = 3 with h* = 0.3, outside the default bounds
    [0, 0.262], lands on 0.262 and says so, and is recovered with wider bounds; a
    dumbbell, C = exp(-t/tau), gives tau alone with h* named undefined."""
    t = np.geomspace(0.5, 200, 40)
    inside = fits.fit_rouse_zimm(t, three_bead_zimm(t, 50.0, 0.15), 3)
    assert inside["longest_relaxation_time"] == pytest.approx(50.0, rel=1e-6)
    assert inside["h_star"] == pytest.approx(0.15, rel=1e-6)
    assert inside.notes == ()

    rouse = fits.fit_rouse_zimm(t, rouse_chain(t, 12, 40.0), 12)
    assert rouse["longest_relaxation_time"] == pytest.approx(40.0, rel=1e-6)
    assert rouse["h_star"] == pytest.approx(0.0, abs=1e-9) and "lower bound" in rouse.notes[0]

    beyond = three_bead_zimm(t, 50.0, 0.3)
    capped = fits.fit_rouse_zimm(t, beyond, 3)
    assert capped["h_star"] == fits.H_STAR_PHYSICAL_RANGE[1] == 0.262
    assert "upper bound" in capped.notes[0]
    wide = fits.fit_rouse_zimm(t, beyond, 3, h_star_bounds=(0.0, 0.4))
    assert wide["h_star"] == pytest.approx(0.3, rel=1e-6)

    dumbbell = fits.fit_rouse_zimm(t, np.exp(-t / 30.0), 2)
    assert dumbbell.names == ("longest_relaxation_time",)
    assert dumbbell["longest_relaxation_time"] == pytest.approx(30.0, rel=1e-9)
    with pytest.raises(KeyError, match="undefined for a dumbbell"):
        dumbbell["h_star"]


def test_rouse_zimm_fit_names_degenerate_and_bad_input():
    t = np.geomspace(0.5, 200, 10)
    with pytest.raises(fits.DegenerateFitError, match="does not decay"):
        fits.fit_rouse_zimm(t, np.ones_like(t), 5)
    # Only t = 0 and a time long past every decay: h* changes nothing (was LinAlgError).
    with pytest.raises(fits.DegenerateFitError, match="h_star"):
        fits.fit_rouse_zimm([0.0, 0.0, 1e5], [1.0, 1.0, 0.0], 5)
    assert issubclass(fits.DegenerateFitError, ValueError)
    curve = three_bead_zimm(t, 50.0, 0.1)
    with pytest.raises(ValueError, match="h_star_bounds"):
        fits.fit_rouse_zimm(t, curve, 3, h_star_bounds=(0.0, 0.6))
    with pytest.raises(ValueError, match="h_star_start"):
        fits.fit_rouse_zimm(t, curve, 3, h_star_start=0.3)
    with pytest.raises(ValueError, match="at least 3 blocks"):
        fits.fit_rouse_zimm(t, np.stack([curve, curve]), 3)
    with pytest.raises(ValueError, match="error must be None"):
        fits.fit_rouse_zimm(t, np.stack([curve] * 3), 3, error=0.01)


def test_rouse_zimm_jackknife_errors_over_blocks_are_calibrated():
    """B blocks, each the exact N = 3 curve (tau_1 = 50, h* = 0.15) plus independent
    Gaussian noise 0.01 per point.  Over R repeats the mean jackknife error matches the
    scatter of the estimates: the scatter is uncertain by 1/sqrt(2(R - 1)) (11 per cent
    for R = 40, 16 per cent for R = 20) and the mean error by about
    1/sqrt(2(B - 1) R) (4 and 3 per cent), so factors 1.4 (B = 8, R = 40) and 1.5
    (B = 32, R = 20) are allowed, 3 combined standard deviations.  More blocks of the
    same noise give smaller errors: 1/sqrt(B) would halve them from 8 to 32 blocks;
    the jackknife variance is biased upwards for few blocks (Efron & Stein, Ann. Stat.
    9, 586 (1981)), so only a fall below 0.6 of the B = 8 error is required."""
    t = np.geomspace(0.5, 200, 30)
    clean = three_bead_zimm(t, 50.0, 0.15)
    rng = np.random.default_rng(3)
    results = {}
    for blocks, repeats in ((8, 40), (32, 20)):
        results[blocks] = [
            fits.fit_rouse_zimm(t, clean + 0.01 * rng.normal(size=(blocks, t.size)), 3)
            for _ in range(repeats)
        ]
    assert "jackknife over 8 blocks" in results[8][0].notes[-1]
    for name, value in (("longest_relaxation_time", 50.0), ("h_star", 0.15)):
        mean_errors = {}
        for blocks, allowed in ((8, 1.4), (32, 1.5)):
            estimates = [r[name] for r in results[blocks]]
            errors = [r.error(name) for r in results[blocks]]
            worst, ratio = calibration(estimates, errors, value)
            assert worst < 4 and 1 / allowed < ratio < allowed, (name, blocks, worst, ratio)
            mean_errors[blocks] = np.mean(errors)
        assert mean_errors[32] < 0.6 * mean_errors[8], (name, mean_errors)
