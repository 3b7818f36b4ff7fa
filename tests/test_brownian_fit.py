"""Gradients of stationary averages and fitting b by gradient (issue 4, must show 5).

Exact reference: at rest the FENE equilibrium gives <Q^2> = 3b/(b+5) (thesis eq. 4.8),
so d<Q^2>/db = 15/(b+5)^2 exactly.  Statistical tolerances: 4 standard errors from
32 independent groups of dumbbells, plus the stated biases: time step (<= 0.2 %, see
test_brownian_rheology.py) and, for the likelihood-ratio estimator, the truncation of
the score window L, bounded by exp(-L / tau) |dA/db| with tau = 1 lambda_H the slowest
relaxation time of Q^2 at rest (Hookean value; FENE relaxes faster).
"""

import math

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from jaxdpd.brownian import (
    FENE,
    fit_spring,
    flow_curve,
    flow_curves,
    likelihood_ratio_sensitivity,
    pathwise_sensitivity,
    stationary_average,
    velocity_gradient,
)

B = 50.0
DT_BIAS = 2e-3


def _q2_and_b(q, spring):
    """Q^2 (depends on b through the distribution) and b itself (explicit dependence
    only: its derivative is exactly 1 for either estimator)."""
    return jnp.stack([q @ q, spring.b + 0 * q[0]])


def test_pathwise_gradient_equals_central_differences():
    """Reverse-mode pathwise gradient (fixed noise, jax.checkpoint every sqrt(n) steps)
    of a finite-run stationary average, d<f Q_x Q_y>/db in shear at De = 2, equals the
    central finite difference of the same estimator (same noise).  The FD truncation
    error is estimated by Richardson, |FD(h) - FD(h/2)|, and the tolerance is 10x that
    plus rounding.  (Forward mode drives the fit below; checkpointing leaves the value
    unchanged, see benchmarks/brownian_throughput.py.)"""
    kappa = velocity_gradient("shear", 2.0)
    run = dict(n_dumbbells=64, n_burn=100, n_average=200, noise="three_point")

    def average(b, checkpoint_every=None):
        out = stationary_average(
            jax.random.key(9), FENE(b), kappa, 0.01, checkpoint_every=checkpoint_every, **run
        )
        return out["fqq"][0, 1]

    value_and_grad = jax.jit(jax.value_and_grad(lambda b: average(b, "sqrt")))
    f = lambda b: value_and_grad(jnp.float64(b))[0]  # noqa: E731  (one compiled program)
    grad_plain = value_and_grad(jnp.float64(B))[1]
    h = 0.5
    fd_h = (f(B + h) - f(B - h)) / (2 * h)
    fd_h2 = (f(B + h / 2) - f(B - h / 2)) / h
    truncation = abs(fd_h - fd_h2)
    rounding = 1e-13 * abs(f(B)) / h
    assert abs(grad_plain - fd_h2) <= 10 * truncation + rounding, (grad_plain, fd_h2)
    assert abs(grad_plain) > 100 * (truncation + rounding)  # a non-trivial derivative


def test_sensitivity_of_equilibrium_size_pathwise_and_likelihood_ratio():
    """Forward-mode pathwise and likelihood-ratio estimates of d<Q^2>/db at rest agree
    with the exact 15/(b+5)^2 (derivative of thesis eq. 4.8); an observable that
    depends on b explicitly (here b itself) gets its derivative, 1, exactly."""
    exact = 15 / (B + 5) ** 2
    kappa = velocity_gradient("equilibrium", 0.0)
    pw = pathwise_sensitivity(
        jax.random.key(1), FENE(B), kappa, 0.02, n_dumbbells=512, n_burn=200,
        n_samples=100, sample_every=10, observable=_q2_and_b, noise="three_point",
    )  # fmt: skip
    der, err = pw.derivative[0, 0], pw.derivative_sem[0, 0]
    assert abs(der - exact) <= 4 * err + DT_BIAS * exact, (der, err, exact)
    assert err < 0.05 * exact
    np.testing.assert_allclose(pw.derivative[0, 1], 1.0, rtol=1e-12)

    window, every, dt = 25, 10, 0.02  # score lag L = 5 lambda_H
    lr = likelihood_ratio_sensitivity(
        jax.random.key(2), FENE(B), kappa, dt, n_dumbbells=512, n_burn=200,
        n_samples=100, sample_every=every, window=window, observable=_q2_and_b,
    )  # fmt: skip
    der, err = lr.derivative[0, 0], lr.derivative_sem[0, 0]
    truncation = math.exp(-window * every * dt / 1.0) * exact
    assert abs(der - exact) <= 4 * err + DT_BIAS * exact + truncation, (der, err, exact)
    assert err < 0.15 * exact
    np.testing.assert_allclose(lr.derivative[0, 1], 1.0, rtol=1e-12)


def test_fit_recovers_b_from_wrong_start():
    """Must show 5.  Synthetic targets: planar elongation at De = 2 and 5 for b = 50
    (eta_bar_1, eta_bar_2 and extension, 512 dumbbells, independent noise).  An optax
    L-BFGS fit of log b from b = 20, with pathwise (forward-mode) gradients of a
    64-dumbbell model, recovers b = 50 within 2 %."""
    targets = [
        flow_curve(
            jax.random.key(1),
            "planar_elongation",
            [2.0, 5.0],
            FENE(B),
            n_dumbbells=512,
            dt=0.01,
            n_equilibrate=400,
            n_samples=40,
            sample_every=10,
            noise="three_point",
        )  # fmt: skip
    ]
    result = fit_spring(
        jax.random.key(3), targets, 20.0, n_dumbbells=64, dt=0.01, n_burn=300,
        n_average=300, n_iterations=6, noise="three_point",
    )  # fmt: skip
    b_fit = float(result.spring.b)
    assert result.b_history[0] == 20.0
    assert abs(b_fit / B - 1) < 0.02, result.b_history
    assert result.loss_history[-1] < 1e-3 * result.loss_history[0]
    assert 0 < result.b_sem < 0.02 * B


@pytest.mark.slow
def test_likelihood_ratio_matches_finite_differences_in_shear():
    """Slow (a few minutes).  In shear at De = 1 the likelihood-ratio and the pathwise
    estimates of d<f Q_x Q_y>/db (= De d eta_p/db) agree with a central finite
    difference of the average (b = 45, 55, common random numbers, 16384 dumbbells),
    within 4 combined standard errors plus the window truncation (L = 6 lambda_H:
    exp(-6) relative)."""
    kappa = velocity_gradient("shear", 1.0)

    def shear_stress(q, spring):
        return spring.force_factor(q @ q) * q[0] * q[1]

    kw = dict(
        n_dumbbells=16384, n_burn=300, n_samples=200, sample_every=10, observable=shear_stress
    )
    lr = likelihood_ratio_sensitivity(jax.random.key(4), FENE(B), kappa, 0.02, window=30, **kw)
    pw = pathwise_sensitivity(jax.random.key(5), FENE(B), kappa, 0.02, **kw)
    plus = pathwise_sensitivity(jax.random.key(6), FENE(B + 5), kappa, 0.02, **kw)
    minus = pathwise_sensitivity(jax.random.key(6), FENE(B - 5), kappa, 0.02, **kw)
    fd = (plus.average[0] - minus.average[0]) / 10
    fd_err = math.hypot(plus.average_sem[0], minus.average_sem[0]) / 10
    est, err = lr.derivative[0, 0], lr.derivative_sem[0, 0]
    assert abs(est - fd) <= 4 * math.hypot(err, fd_err) + math.exp(-6) * abs(fd), (est, fd)
    est, err = pw.derivative[0, 0], pw.derivative_sem[0, 0]
    assert abs(est - fd) <= 4 * math.hypot(err, fd_err), (est, fd)


@pytest.mark.slow
def test_fit_with_gaussian_noise_and_independent_targets():
    """Slow (a few minutes).  Gaussian noise throughout; targets from 8192 dumbbells per
    rate (planar elongation De = 2, 5 and shear De = 10, all material functions and the
    extension), model of 512 dumbbells with independent noise: b = 50 recovered from
    b = 20 within 2 % and within 4 Gauss-Newton standard errors (target and model noise
    combined: the model's variance is 8192/512 times the targets')."""
    curves = flow_curves(
        jax.random.key(7), {"planar_elongation": [2.0, 5.0], "shear": [10.0]}, FENE(B),
        n_dumbbells=8192, dt=0.01, n_equilibrate=500, n_samples=50, sample_every=10,
    )  # fmt: skip
    result = fit_spring(
        jax.random.key(8), list(curves.values()), 20.0, n_dumbbells=512, n_burn=500,
        n_average=500, n_iterations=8,
    )  # fmt: skip
    b_fit = float(result.spring.b)
    assert abs(b_fit / B - 1) < 0.02, result.b_history
    assert abs(b_fit - B) <= 4 * math.sqrt(1 + 8192 / 512) * result.b_sem
