"""Fits for polymer analysis: power laws, end-to-end relaxation, Rouse–Zimm correlation.

Analysis steps on measured curves (NumPy, outside ``jit``; scipy is not a runtime
dependency).  Each fit returns a :class:`FitResult` with the parameter covariance:

- with per-point standard errors ``sigma``: weighted least squares, covariance
  ``(J^T W J)^-1`` with ``W = diag(1/sigma^2)`` (errors taken as absolute);
- without: unweighted least squares, covariance scaled by the residual variance
  ``chi^2/(n - k)`` (errors estimated from the scatter of the points).

Either way the points are assumed independent.  Points of one correlation function or
MSD curve are correlated, which makes these error bars too small; for honest errors
fit independent samples (replicas, chains, blocks) separately and use the scatter of
the fitted values (:func:`jaxdpd.statistics.block_average`).

Nonlinear fits use Levenberg–Marquardt (Press et al., *Numerical Recipes*, 3rd ed.
(2007), sec. 15.5.2) with a central-difference Jacobian; positive parameters are
fitted through their logarithm.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from jaxdpd.observables._checks import positive_int

__all__ = [
    "FitResult",
    "exponential_relaxation",
    "fit_end_to_end_relaxation",
    "fit_power_law",
    "fit_rouse_zimm",
    "rouse_zimm_correlation",
    "zimm_relaxation_times",
]


@dataclasses.dataclass(frozen=True)
class FitResult:
    """Fitted parameters with their standard errors and covariance.

    Attributes:
      names: parameter names, in the order of ``values``.
      values: NumPy ``(k,)`` fitted values.
      errors: NumPy ``(k,)`` standard errors, ``sqrt(diag(covariance))``.
      covariance: NumPy ``(k, k)`` covariance of ``values``.
      chi_squared: sum of squared (weighted) residuals at the optimum.
      degrees_of_freedom: number of points minus number of parameters.
    """

    names: tuple[str, ...]
    values: np.ndarray
    errors: np.ndarray
    covariance: np.ndarray
    chi_squared: float
    degrees_of_freedom: int

    def __getitem__(self, name: str) -> float:
        return float(self.values[self.names.index(name)])

    def error(self, name: str) -> float:
        return float(self.errors[self.names.index(name)])


def _data(x, y, sigma, x_name: str = "x", y_name: str = "y", positive: bool = False):
    x = np.asarray(x, dtype=np.float64)
    y = np.asarray(y, dtype=np.float64)
    if x.ndim != 1 or y.shape != x.shape:
        raise ValueError(
            f"{x_name} and {y_name} must be 1-d arrays of equal length, got {x.shape} and {y.shape}"
        )
    if not (np.all(np.isfinite(x)) and np.all(np.isfinite(y))):
        raise ValueError(f"{x_name} and {y_name} must be finite")
    if positive and not (np.all(x > 0) and np.all(y > 0)):
        raise ValueError(f"{x_name} and {y_name} must be positive for a power-law fit")
    if sigma is not None:
        sigma = np.broadcast_to(np.asarray(sigma, dtype=np.float64), x.shape)
        if not np.all(sigma > 0):
            raise ValueError(f"{y_name}_error must be positive wherever given")
    return x, y, sigma


def _finish(names, values, covariance, residuals, sigma, n_params):
    dof = residuals.size - n_params
    chi2 = float(residuals @ residuals)
    if sigma is None:
        if dof < 1:
            raise ValueError(
                f"an error estimate without given errors needs more than {n_params} points"
            )
        covariance = covariance * chi2 / dof
    return FitResult(
        tuple(names),
        np.asarray(values, dtype=np.float64),
        np.sqrt(np.diag(covariance)),
        covariance,
        chi2,
        dof,
    )


def fit_power_law(x, y, y_error=None) -> FitResult:
    """Fit ``y = A x^nu`` by linear least squares in log-log.

    ``ln y = ln A + nu ln x`` with the errors ``sigma_ln y = sigma_y / y`` (first order)
    when ``y_error`` is given, weights 1 otherwise.  The covariance of ``(ln A, nu)``
    is ``(X^T W X)^-1`` (scaled by the residual variance without given errors), and
    ``sigma_A = A sigma_lnA``.

    Args:
      x, y: ``(n,)`` positive values, ``n >= 3`` (``>= 2`` with ``y_error``).
      y_error: optional ``(n,)`` (or scalar) standard errors of ``y``.

    Returns:
      :class:`FitResult` with ``names = ("amplitude", "exponent")``; ``covariance`` is
      that of ``(amplitude, exponent)`` (propagated from ``(ln A, nu)``).
    """
    x, y, sigma = _data(x, y, y_error, positive=True)
    design = np.stack([np.ones_like(x), np.log(x)], axis=1)
    weight = np.ones_like(x) if sigma is None else (y / sigma) ** 2
    if x.size < 2 or np.ptp(np.log(x)) == 0:
        raise ValueError("a power-law fit needs at least 2 distinct x values")
    normal = design.T @ (weight[:, None] * design)
    covariance_log = np.linalg.inv(normal)
    log_amplitude, exponent = covariance_log @ (design.T @ (weight * np.log(y)))
    residuals = np.sqrt(weight) * (np.log(y) - design @ [log_amplitude, exponent])
    amplitude = np.exp(log_amplitude)
    to_linear = np.diag([amplitude, 1.0])
    return _finish(
        ("amplitude", "exponent"),
        (amplitude, exponent),
        to_linear @ covariance_log @ to_linear,
        residuals,
        sigma,
        2,
    )


def _jacobian(residual, params, scale):
    columns = []
    for i in range(params.size):
        step = 1e-6 * max(abs(params[i]), scale[i])
        delta = np.zeros_like(params)
        delta[i] = step
        columns.append((residual(params + delta) - residual(params - delta)) / (2 * step))
    return np.stack(columns, axis=1)


def _levenberg_marquardt(residual, params, max_iterations: int = 200):
    """Minimise ``|residual(params)|^2``; returns ``(params, J, residuals)``."""
    params = np.asarray(params, dtype=np.float64)
    scale = np.maximum(np.abs(params), 1e-3)
    r = residual(params)
    chi2 = r @ r
    damping = 1e-3
    for _ in range(max_iterations):
        jac = _jacobian(residual, params, scale)
        normal = jac.T @ jac
        gradient = jac.T @ r
        improved = False
        while damping < 1e12:
            step = np.linalg.solve(normal + damping * np.diag(np.diag(normal)), -gradient)
            trial = params + step
            r_trial = residual(trial)
            chi2_trial = r_trial @ r_trial
            if np.isfinite(chi2_trial) and chi2_trial <= chi2:
                improved = True
                break
            damping *= 10
        if not improved:
            break
        converged = chi2 - chi2_trial <= 1e-12 * max(chi2, 1e-300) and np.all(
            np.abs(step) <= 1e-9 * np.maximum(np.abs(params), 1e-9) + 1e-12
        )
        params, r, chi2 = trial, r_trial, chi2_trial
        damping = max(damping / 10, 1e-12)
        if converged or chi2 == 0:
            break
    return params, _jacobian(residual, params, scale), r


def exponential_relaxation(t, amplitude, relaxation_time, plateau):
    """Thesis eq. 5.15: ``L^2(t) = L_0^2 exp(-t/lambda_0) + L_e^2``.

    Args:
      t: times since the flow was stopped.
      amplitude: ``L_0^2``, the initial excess of ``<R_e^2>`` over equilibrium.
      relaxation_time: ``lambda_0``, the longest relaxation time.
      plateau: ``L_e^2``, the equilibrium ``<R_e^2>``.

    Returns:
      ``<R_e^2>(t)`` as a NumPy array.
    """
    return amplitude * np.exp(-np.asarray(t) / relaxation_time) + plateau


def fit_end_to_end_relaxation(times, end_to_end_squared, error=None) -> FitResult:
    """Longest relaxation time from the relaxation of stretched chains (thesis eq. 5.15).

    Chains stretched by a strong flow relax after the flow stops; ``<R_e^2>(t)`` is
    fitted to ``A exp(-t/lambda_0) + B`` (Clarke thesis sec. 5.4.1, "Determination of
    Longest Relaxation Time"; there ``A = L_0^2``, ``B = L_e^2``).  Start values: ``B``
    from the last tenth of the curve, ``A = y(0) - B``, ``lambda_0`` from the time at
    which the excess falls below ``A/e``.  Use times late enough for the faster modes to
    have relaxed if the fit must report the longest time only.

    Args:
      times: ``(n,)`` times since the flow was stopped, ``n >= 4``.
      end_to_end_squared: ``(n,)`` mean ``<R_e^2>`` at those times (units r_c^2).
      error: optional ``(n,)`` standard errors of ``end_to_end_squared``.

    Returns:
      :class:`FitResult` with names ``("amplitude", "relaxation_time", "plateau")``.
    """
    t, y, sigma = _data(times, end_to_end_squared, error, "times", "end_to_end_squared")
    if t.size < 4:
        raise ValueError(f"the relaxation fit needs at least 4 points, got {t.size}")
    weight = 1.0 if sigma is None else 1.0 / sigma
    tail = max(1, t.size // 10)
    plateau0 = float(np.mean(y[np.argsort(t)[-tail:]]))
    amplitude0 = float(y[np.argmin(t)] - plateau0)
    below = np.flatnonzero((y - plateau0) * np.sign(amplitude0) < abs(amplitude0) / np.e)
    tau0 = float(t[below[0]] - t.min()) if below.size else float(np.ptp(t))
    tau0 = max(tau0, float(np.ptp(t)) / (10 * t.size))

    def residual(p):
        return weight * (exponential_relaxation(t, p[0], np.exp(p[1]), p[2]) - y)

    p, jac, r = _levenberg_marquardt(residual, [amplitude0, np.log(tau0), plateau0])
    covariance = np.linalg.pinv(jac.T @ jac)
    to_linear = np.diag([1.0, np.exp(p[1]), 1.0])
    return _finish(
        ("amplitude", "relaxation_time", "plateau"),
        (p[0], np.exp(p[1]), p[2]),
        to_linear @ covariance @ to_linear,
        r,
        sigma,
        3,
    )


def _mode_coupling(n_beads: int):
    """``K_p = (2 sqrt 2 / N) sum_{n != m} c_n c_m / sqrt|n - m|`` for p = 1 .. N-1."""
    p = np.arange(1, n_beads)[:, None]
    n = np.arange(1, n_beads + 1)
    basis = np.cos(p * np.pi * (n - 0.5) / n_beads)
    separation = np.abs(n[:, None] - n[None, :]).astype(np.float64)
    kernel = np.where(separation > 0, 1.0 / np.sqrt(np.where(separation > 0, separation, 1)), 0)
    return 2 * np.sqrt(2) / n_beads * np.einsum("pn,nm,pm->p", basis, kernel, basis)


@dataclasses.dataclass(frozen=True)
class _RouseZimmTerms:
    """``sin^2(p pi/2N)``, the couplings ``K_p`` and the weights ``w_p``, p = 1 .. N-1."""

    sin2: np.ndarray
    coupling: np.ndarray
    weights: np.ndarray

    @classmethod
    def of(cls, n_beads: int):
        p = np.arange(1, n_beads)
        sin2 = np.sin(p * np.pi / (2 * n_beads)) ** 2
        return cls(sin2, _mode_coupling(n_beads), (1 / sin2) / np.sum(1 / sin2))


def _mode_rates(terms: _RouseZimmTerms, h_star):
    """Decay rates in units of ``4H/zeta``: ``sin^2(p pi/2N) (1 + h* K_p)``."""
    return terms.sin2 * (1 + h_star * terms.coupling)


def _correlation(t, terms: _RouseZimmTerms, longest_relaxation_time, h_star):
    rate = _mode_rates(terms, h_star)
    return np.exp(-t[..., None] * rate / (rate[0] * longest_relaxation_time)) @ terms.weights


def _check_h_star(h_star, n_beads):
    if not 0 <= h_star < 0.547 or np.any(_mode_rates(_RouseZimmTerms.of(n_beads), h_star) <= 0):
        raise ValueError(
            f"h_star must lie in [0, 0.547) (the range in which the preaveraged Zimm "
            f"matrix is positive definite, Fong & Peterlin 1976), got {h_star!r}"
        )


def zimm_relaxation_times(n_beads: int, h_star: float, time_unit: float = 1.0):
    """Relaxation times of the Rouse modes of a Rouse–Zimm chain, p = 1 .. N-1.

    Bead-spring chain of N beads, Hookean springs H, bead friction zeta, preaveraged
    Oseen hydrodynamic interaction ``zeta <Omega_ij> = sqrt(2) h* / sqrt|i - j|``
    (``h* = a sqrt(H/(pi k_BT))``, ``a`` the bead's Stokes radius; Bird, Curtiss,
    Armstrong & Hassager, *Dynamics of Polymeric Liquids* vol. 2, 2nd ed. (1987),
    ch. 15).  Keeping only the diagonal of the hydrodynamic matrix in the basis of the
    Rouse modes ``c_p(n) = cos(p pi (n - 1/2)/N)`` (the approximation of Mussawisade et
    al., J. Chem. Phys. 123, 144905 (2005), eq. 19 and the text after it) gives the
    decay time of ``<X_p(t) . X_p(0)>``

        tau_p = (zeta / H) / (4 sin^2(p pi / 2N) [1 + h* K_p]),
        K_p = (2 sqrt(2) / N) sum_{n != m} c_p(n) c_p(m) / sqrt|n - m|.

    ``h* = 0`` is the Rouse model; for ``N = 2`` it is the exact preaveraged-HI
    dumbbell ``zeta / (2H (1 - sqrt(2) h*))``; for large ``h* K_p`` it gives
    ``tau_p ~ (p/N)^(1/2) / sin^2(p pi/N)`` (Mussawisade eq. 19).  Against the exact
    eigenvalues of Zimm's matrix ``H.A`` (Zimm, J. Chem. Phys. 24, 269 (1956)) the
    approximation is within 1.4 per cent for N = 20, h* = 0.25, p <= 4 (3 per cent at
    h* = 0.4), slightly short of the exact times (tests/test_polymer_fits.py).

    This is not the Thurston approximation of the Zimm eigenvalues: Clarke's thesis as
    available in ``shared/seeds`` contains neither that approximation nor a Rouse–Zimm
    fit, so the documented diagonal approximation is used instead.

    Args:
      n_beads: N >= 2.
      h_star: hydrodynamic interaction parameter ``h*`` in [0, 0.547).
      time_unit: ``zeta / H`` (time units), positive.

    Returns:
      NumPy ``(N - 1,)`` relaxation times ``tau_p`` in the units of ``time_unit``.
    """
    n = positive_int(n_beads, "n_beads", minimum=2)
    if not time_unit > 0:
        raise ValueError(f"time_unit must be positive, got {time_unit!r}")
    _check_h_star(h_star, n)
    return time_unit / (4 * _mode_rates(_RouseZimmTerms.of(n), h_star))


def rouse_zimm_correlation(t, n_beads: int, longest_relaxation_time: float, h_star: float):
    """Positional autocorrelation ``C(t)`` of a Rouse–Zimm chain.

    ``C(t) = sum_p w_p exp(-t/tau_p)`` over p = 1 .. N-1 with the static Gaussian-chain
    weights ``w_p = sin^-2(p pi/2N) / sum_q sin^-2(q pi/2N)`` (the Rouse amplitudes
    ``<X_p^2>``, :func:`jaxdpd.observables.conformation.gaussian_chain_rouse_amplitudes`;
    hydrodynamic interaction does not change statics) and ``tau_p`` from
    :func:`zimm_relaxation_times`, rescaled so that ``tau_1`` is the given one.  ``C``
    is the quantity of
    :func:`jaxdpd.observables.dynamics.positional_autocorrelation`.

    Args:
      t: times (any shape), ``>= 0``.
      n_beads, h_star: as :func:`zimm_relaxation_times`.
      longest_relaxation_time: ``tau_1`` (time units), positive.

    Returns:
      NumPy array of the shape of ``t``; ``C(0) = 1``.
    """
    n = positive_int(n_beads, "n_beads", minimum=2)
    if not longest_relaxation_time > 0:
        raise ValueError(
            f"longest_relaxation_time must be positive, got {longest_relaxation_time!r}"
        )
    _check_h_star(h_star, n)
    t = np.asarray(t, dtype=np.float64)
    return _correlation(t, _RouseZimmTerms.of(n), longest_relaxation_time, h_star)


def fit_rouse_zimm(times, correlation, n_beads: int, error=None, h_star_start: float = 0.1):
    """Fit ``tau_1`` and ``h*`` of the Rouse–Zimm ``C(t)`` (:func:`rouse_zimm_correlation`).

    Args:
      times: ``(n,)`` lag times (time units), ``n >= 3``.
      correlation: ``(n,)`` measured normalised ``C(t)``.
      n_beads: N, beads per chain.
      error: optional ``(n,)`` standard errors of ``correlation``.
      h_star_start: start value of ``h*``.

    Returns:
      :class:`FitResult` with names ``("longest_relaxation_time", "h_star")``.  The
      start value of ``tau_1`` is the time at which ``C`` first falls below ``1/e``.
      ``h*`` is not constrained to [0, 0.547): a fitted value below 0 (within its
      error of 0) is consistent with Rouse dynamics; one outside the range by many
      standard errors means the model does not describe the data.
    """
    t, c, sigma = _data(times, correlation, error, "times", "correlation")
    n = positive_int(n_beads, "n_beads", minimum=2)
    if t.size < 3:
        raise ValueError(f"the Rouse–Zimm fit needs at least 3 points, got {t.size}")
    _check_h_star(h_star_start, n)
    weight = 1.0 if sigma is None else 1.0 / sigma
    below = np.flatnonzero(c < 1 / np.e)
    tau0 = float(t[below[0]]) if below.size else float(t.max())
    terms = _RouseZimmTerms.of(n)

    def residual(params):
        if np.any(_mode_rates(terms, params[1]) <= 0):
            return np.full(t.shape, np.inf)
        return weight * (_correlation(t, terms, np.exp(params[0]), params[1]) - c)

    params, jac, r = _levenberg_marquardt(residual, [np.log(max(tau0, 1e-12)), h_star_start])
    covariance = np.linalg.pinv(jac.T @ jac)
    to_linear = np.diag([np.exp(params[0]), 1.0])
    return _finish(
        ("longest_relaxation_time", "h_star"),
        (np.exp(params[0]), params[1]),
        to_linear @ covariance @ to_linear,
        r,
        sigma,
        2,
    )
