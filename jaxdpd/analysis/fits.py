"""Fits for polymer analysis: power laws, end-to-end relaxation, Rouse–Zimm correlation.

Analysis steps on measured curves (NumPy, outside ``jit``; scipy is not a runtime
dependency).  Each fit returns a :class:`FitResult` with the parameter covariance:

- with per-point standard errors ``sigma``: weighted least squares, covariance
  ``(J^T W J)^-1`` with ``W = diag(1/sigma^2)`` (errors taken as absolute);
- without: unweighted least squares, covariance scaled by the residual variance
  ``chi^2/(n - k)`` (errors estimated from the scatter of the points).

Either way the points are assumed independent.  Points of one correlation function or
MSD curve are correlated, which makes these error bars too small; for honest errors
give independent curves (replicas, chains, blocks of a run): :func:`fit_rouse_zimm`
then fits their mean and takes the errors from the jackknife over them
(:func:`jackknife`).

Data that cannot determine a parameter raise :class:`DegenerateFitError` (a
``ValueError``) naming it, never a bare ``numpy.linalg.LinAlgError``.

Nonlinear fits use Levenberg–Marquardt (Press et al., *Numerical Recipes*, 3rd ed.
(2007), sec. 15.5.2) with a central-difference Jacobian; positive parameters are
fitted through their logarithm, bounded ones by projection onto their interval with
the parameters held at a bound the gradient pushes against left out of the step (an
active-set projected Levenberg–Marquardt; Nocedal & Wright, *Numerical Optimization*,
2nd ed. (2006), sec. 16.7 on gradient projection).
"""

from __future__ import annotations

import dataclasses

import numpy as np

from jaxdpd.analysis._checks import positive_int

__all__ = [
    "H_STAR_PHYSICAL_RANGE",
    "DegenerateFitError",
    "FitResult",
    "exponential_relaxation",
    "fit_end_to_end_relaxation",
    "fit_power_law",
    "fit_rouse_zimm",
    "jackknife",
    "rouse_zimm_correlation",
    "zimm_relaxation_times",
]


H_STAR_PHYSICAL_RANGE = (0.0, 0.262)
"""Default bounds of the fitted hydrodynamic interaction parameter ``h*`` (issue 29):
from the free-draining (Rouse) chain, ``h* = 0``, to 0.262, the upper end of the
physical range the issue names."""


class DegenerateFitError(ValueError):
    """The data cannot determine (some of) the fitted parameters.

    Raised instead of a singular-matrix error, e.g. when a parameter does not change
    the model at the given times, or the curve does not decay at all.
    """


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
      notes: remarks on the result: parameters at a bound, parameters the model
        does not have (the dumbbell's ``h*``), how the errors were estimated.
    """

    names: tuple[str, ...]
    values: np.ndarray
    errors: np.ndarray
    covariance: np.ndarray
    chi_squared: float
    degrees_of_freedom: int
    notes: tuple[str, ...] = ()

    def _index(self, name: str) -> int:
        if name not in self.names:
            raise KeyError(
                f"{name!r} is not a fitted parameter; this fit has {self.names}"
                + "".join(f"; {note}" for note in self.notes)
            )
        return self.names.index(name)

    def __getitem__(self, name: str) -> float:
        return float(self.values[self._index(name)])

    def error(self, name: str) -> float:
        return float(self.errors[self._index(name)])


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


def _finish(names, values, covariance, residuals, sigma, n_params, notes=()):
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
        tuple(notes),
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


def _solve(normal, gradient, names):
    """Solve the damped normal equations; a singular system names its parameters."""
    try:
        return np.linalg.solve(normal, gradient)
    except np.linalg.LinAlgError:
        idle = [names[i] for i in np.flatnonzero(np.diag(normal) == 0)]
        raise DegenerateFitError(
            f"the data do not determine {idle or list(names)}: the model does not change "
            "with them at the given times (singular normal equations)"
        ) from None


def _levenberg_marquardt(
    residual, params, names, lower=None, upper=None, max_iterations: int = 200
):
    """Minimise ``|residual(params)|^2`` within ``[lower, upper]``.

    Returns ``(params, J, residuals)``.  ``residual`` must be finite slightly beyond
    the bounds (the Jacobian's central differences step across them).
    """
    params = np.asarray(params, dtype=np.float64)
    lower = np.full_like(params, -np.inf) if lower is None else np.asarray(lower, np.float64)
    upper = np.full_like(params, np.inf) if upper is None else np.asarray(upper, np.float64)
    scale = np.maximum(np.abs(params), 1e-3)
    r = residual(params)
    chi2 = r @ r
    damping = 1e-3
    for _ in range(max_iterations):
        jac = _jacobian(residual, params, scale)
        gradient = jac.T @ r
        # Parameters at a bound that the descent direction pushes against stay there.
        held = ((params <= lower) & (gradient > 0)) | ((params >= upper) & (gradient < 0))
        free = ~held
        if not free.any():
            break
        normal = jac[:, free].T @ jac[:, free]
        improved = False
        while damping < 1e12:
            step = np.zeros_like(params)
            step[free] = _solve(
                normal + damping * np.diag(np.diag(normal)),
                -gradient[free],
                [n for n, f in zip(names, free, strict=True) if f],
            )
            trial = np.clip(params + step, lower, upper)
            r_trial = residual(trial)
            chi2_trial = r_trial @ r_trial
            if np.isfinite(chi2_trial) and chi2_trial <= chi2:
                improved = True
                break
            damping *= 10
        if not improved:
            break
        moved = trial - params
        converged = chi2 - chi2_trial <= 1e-12 * max(chi2, 1e-300) and np.all(
            np.abs(moved) <= 1e-9 * np.maximum(np.abs(params), 1e-9) + 1e-12
        )
        params, r, chi2 = trial, r_trial, chi2_trial
        damping = max(damping / 10, 1e-12)
        if converged or chi2 == 0:
            break
    return params, _jacobian(residual, params, scale), r


def _covariance(jac, names):
    """``(J^T J)^-1``; a rank-deficient Jacobian raises :class:`DegenerateFitError`."""
    normal = jac.T @ jac
    columns = np.sqrt(np.diag(normal))
    if np.any(columns == 0) or np.linalg.matrix_rank(jac / np.where(columns > 0, columns, 1)) < (
        len(names)
    ):
        idle = [n for n, c in zip(names, columns, strict=True) if c == 0] or list(names)
        raise DegenerateFitError(
            f"the data do not determine {idle}: the model's derivatives with respect to "
            "them vanish or are linearly dependent at the optimum"
        )
    return np.linalg.inv(normal)


def jackknife(fit: FitResult, refit, blocks) -> FitResult:
    """``fit`` with its covariance from the delete-one jackknife over blocks.

    With ``theta_k = refit(blocks without block k)`` for each of the ``B`` blocks,
    ``cov = ((B - 1)/B) sum_k (theta_k - mean theta)(theta_k - mean theta)^T``
    (Efron & Stein, Ann. Stat. 9, 586 (1981); Efron, *The Jackknife, the Bootstrap and
    Other Resampling Plans* (1982), ch. 3).  Honest for points correlated in time as
    long as the blocks are independent (replicas, chains, or blocks of a run longer
    than the correlation time).

    Args:
      fit: the fit of all blocks together.
      refit: ``refit(others)`` → the :class:`FitResult` of the ``(B - 1, ...)``
        blocks left; its parameters must be those of ``fit``.
      blocks: ``(B, ...)`` array, ``B >= 3``.

    Returns:
      ``fit`` with the jackknife ``covariance`` and ``errors`` and a note saying so.
    """
    blocks = np.asarray(blocks)
    count = len(blocks)
    if count < 3:
        raise ValueError(f"blocks: the jackknife needs at least 3 blocks, got {count}")
    values = np.stack([refit(np.delete(blocks, k, axis=0)).values for k in range(count)])
    deviations = values - values.mean(axis=0)
    covariance = (count - 1) / count * deviations.T @ deviations
    return dataclasses.replace(
        fit,
        errors=np.sqrt(np.diag(covariance)),
        covariance=covariance,
        notes=(*fit.notes, f"errors: delete-one jackknife over {count} blocks"),
    )


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

    names = ("amplitude", "relaxation_time", "plateau")
    p, jac, r = _levenberg_marquardt(residual, [amplitude0, np.log(tau0), plateau0], names)
    covariance = _covariance(jac, names)
    to_linear = np.diag([1.0, np.exp(p[1]), 1.0])
    return _finish(
        names,
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

    For N = 3 the approximation is exact: the Rouse modes are then eigenvectors of
    ``H.A`` modulo the centre of mass, with eigenvalues ``1 - h*`` and
    ``3 - 4 sqrt(2) h* + h*`` (tests/test_polymer_fits.py derives them by hand).

    This is not the Thurston approximation of the Zimm eigenvalues (Thurston & Morrison,
    Polymer 10, 421 (1969); Thurston, Polymer 15, 569 (1974)): no source available to
    this project (``shared/seeds``, Clarke's thesis included) states its formula, so the
    documented diagonal approximation is used instead.

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
    ``<X_p^2>``, :func:`jaxdpd.analysis.conformation.gaussian_chain_rouse_amplitudes`;
    hydrodynamic interaction does not change statics) and ``tau_p`` from
    :func:`zimm_relaxation_times`, rescaled so that ``tau_1`` is the given one.  ``C``
    is the quantity of
    :func:`jaxdpd.analysis.dynamics.positional_autocorrelation`.

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


def _h_star_bounds(h_star_bounds, n_beads: int):
    try:
        lower, upper = (float(b) for b in h_star_bounds)
    except (TypeError, ValueError):
        raise ValueError(
            f"h_star_bounds must be a pair (lower, upper), got {h_star_bounds!r}"
        ) from None
    if not 0 <= lower < upper < 0.547:
        raise ValueError(
            f"h_star_bounds must satisfy 0 <= lower < upper < 0.547 (the range in which "
            f"the preaveraged Zimm matrix is positive definite), got {h_star_bounds!r}"
        )
    _check_h_star(upper, n_beads)
    return lower, upper


def _curves(times, correlation, error):
    """``(t, mean curve, its errors or None, blocks (B, n) or None)``."""
    blocks = np.asarray(correlation, dtype=np.float64)
    if blocks.ndim == 2:
        if error is not None:
            raise ValueError(
                "error must be None when correlation has a block axis (B, n): the "
                "errors come from the scatter of the blocks"
            )
        if blocks.shape[0] < 3:
            raise ValueError(
                f"correlation: a block axis needs at least 3 blocks for the jackknife, "
                f"got shape {blocks.shape}"
            )
        mean = blocks.mean(axis=0)
        error = blocks.std(axis=0, ddof=1) / np.sqrt(blocks.shape[0])
        if not np.all(error > 0):
            raise DegenerateFitError(
                "correlation: the blocks agree exactly at some times, so their scatter "
                "gives no error there; give blocks that scatter independently"
            )
        t, c, sigma = _data(times, mean, error, "times", "correlation")
        return t, c, sigma, blocks
    if blocks.ndim != 1:
        raise ValueError(f"correlation must have shape (n,) or (B, n) (blocks), got {blocks.shape}")
    t, c, sigma = _data(times, blocks, error, "times", "correlation")
    return t, c, sigma, None


def fit_rouse_zimm(
    times,
    correlation,
    n_beads: int,
    error=None,
    h_star_start: float = 0.1,
    h_star_bounds=H_STAR_PHYSICAL_RANGE,
) -> FitResult:
    """Fit ``tau_1`` and ``h*`` of the Rouse–Zimm ``C(t)`` (:func:`rouse_zimm_correlation`).

    ``h*`` is fitted within ``h_star_bounds`` (default [0, 0.262],
    :data:`H_STAR_PHYSICAL_RANGE`) by projected Levenberg–Marquardt (module docstring);
    a value at a bound is reported as such in ``notes``, with the error from the
    curvature of ``chi^2`` there (one-sided: the constrained estimate cannot move past
    the bound).  ``tau_1`` is fitted through its logarithm.  The model's mode times are
    those of :func:`zimm_relaxation_times` (the diagonal approximation, exact for
    N = 2 and 3; not Thurston's approximation, see there).

    A dumbbell (``n_beads = 2``) has one mode: ``C(t) = exp(-t/tau_1)`` exactly for
    every ``h*`` (which only sets ``tau_1`` in units of ``zeta/H``, see
    :func:`zimm_relaxation_times`), so it is fitted as that single exponential and
    the result has ``tau_1`` alone, with a note that ``h*`` is undefined
    (``result["h_star"]`` raises ``KeyError`` saying so).

    Errors: with ``correlation`` of shape ``(B, n)`` (B >= 3 independent curves:
    replicas, chains or blocks of a run, e.g. from
    :func:`jaxdpd.observables.chain_correlators.positional_autocorrelation` of each
    replica) the mean curve is fitted, weighted by its standard errors over the
    blocks, and the covariance is the delete-one jackknife over the blocks
    (:func:`jackknife`), honest for points correlated in time.  With a single curve
    ``(n,)`` the covariance is the least-squares one (module docstring), which treats
    the points as independent and is too small for points of one correlation function.

    Args:
      times: ``(n,)`` lag times (time units), ``n >= 3``.
      correlation: ``(n,)`` measured normalised ``C(t)``, or ``(B, n)`` one curve per
        block.
      n_beads: N >= 2, beads per chain.
      error: optional ``(n,)`` standard errors of a single curve (None with blocks).
      h_star_start: start value of ``h*``, within ``h_star_bounds``.
      h_star_bounds: ``(lower, upper)`` with ``0 <= lower < upper < 0.547``.

    Returns:
      :class:`FitResult` with names ``("longest_relaxation_time", "h_star")`` (or
      ``("longest_relaxation_time",)`` for a dumbbell).  The start value of ``tau_1``
      is the time at which ``C`` first falls below ``1/e``.

    Raises:
      ValueError: bad arguments, named.
      DegenerateFitError: the data cannot determine a parameter (e.g. ``C`` does not
        decay over the times given, or every time is past the decay of all modes
        but the first, so that ``h*`` has no effect).
    """
    n = positive_int(n_beads, "n_beads", minimum=2)
    t, c, sigma, blocks = _curves(times, correlation, error)
    if t.size < 3:
        raise ValueError(f"the Rouse–Zimm fit needs at least 3 points, got {t.size}")
    lower, upper = _h_star_bounds(h_star_bounds, n)
    if not lower <= h_star_start <= upper:
        raise ValueError(
            f"h_star_start must lie within h_star_bounds {(lower, upper)}, got {h_star_start!r}"
        )
    first, last = np.argmin(t), np.argmax(t)
    if not c[last] < c[first]:
        raise DegenerateFitError(
            f"correlation does not decay: C = {float(c[last])} at the longest time "
            f"{float(t[last])} is not below C = {float(c[first])} at the shortest time "
            f"{float(t[first])}, so no relaxation time can be fitted"
        )
    below = np.flatnonzero(c < 1 / np.e)
    tau_start = max(float(t[below[0]]) if below.size else float(t.max()), 1e-12)
    fit = _rouse_zimm_fit(t, c, sigma, n, tau_start, h_star_start, lower, upper)
    if blocks is None:
        return fit

    def refit(others):
        error = others.std(axis=0, ddof=1) / np.sqrt(len(others))
        return _rouse_zimm_fit(
            t, others.mean(axis=0), error, n, tau_start, h_star_start, lower, upper
        )

    return jackknife(fit, refit, blocks)


def _rouse_zimm_fit(t, c, sigma, n_beads, tau_start, h_star_start, lower, upper):
    weight = 1.0 if sigma is None else 1.0 / sigma
    if n_beads == 2:
        names = ("longest_relaxation_time",)

        def single(params):
            return weight * (np.exp(-t / np.exp(params[0])) - c)

        params, jac, r = _levenberg_marquardt(single, [np.log(tau_start)], names)
        covariance = _covariance(jac, names)
        tau = np.exp(params[0])
        note = (
            "h_star is undefined for a dumbbell: its single mode gives C(t) = "
            "exp(-t/tau_1) whatever h* (h* sets tau_1 in units of zeta/H only)"
        )
        return _finish(names, (tau,), tau**2 * covariance, r, sigma, 1, (note,))

    names = ("longest_relaxation_time", "h_star")
    terms = _RouseZimmTerms.of(n_beads)

    def residual(params):
        return weight * (_correlation(t, terms, np.exp(params[0]), params[1]) - c)

    params, jac, r = _levenberg_marquardt(
        residual,
        [np.log(tau_start), h_star_start],
        names,
        lower=[-np.inf, lower],
        upper=[np.inf, upper],
    )
    covariance = _covariance(jac, names)
    notes = []
    for bound, side in ((lower, "lower"), (upper, "upper")):
        # Within the optimiser's step tolerance of the bound (see _levenberg_marquardt).
        if abs(params[1] - bound) <= 1e-9:
            notes.append(
                f"h_star is at its {side} bound {bound} (h_star_bounds); its error is "
                "the curvature of chi^2 there"
            )
    to_linear = np.diag([np.exp(params[0]), 1.0])
    return _finish(
        names,
        (np.exp(params[0]), params[1]),
        to_linear @ covariance @ to_linear,
        r,
        sigma,
        2,
        notes,
    )
