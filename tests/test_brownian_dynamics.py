"""The semi-implicit predictor–corrector and its pieces (jaxdpd.brownian.dynamics/springs)."""

import math

import jax
import jax.numpy as jnp
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from jaxdpd.brownian import (
    FENE,
    Hookean,
    equilibrium_state,
    ottinger_step,
    predictor_corrector,
    simulate,
    state_from_connectors,
    velocity_gradient,
    wiener_increments,
)
from jaxdpd.brownian.increments import _log_unit
from jaxdpd.trigonometry import trisected_cosine


def _poly_residual(length, r, h, b):
    """Backward error of the FENE cubic l^3 - R l^2 - b(1+h) l + b R = 0 relative to the
    size of its terms (Öttinger 1996 ch. 4; springs.py docstring)."""
    terms = np.abs([length**3, r * length**2, b * (1 + h) * length, b * r]).sum()
    value = length**3 - r * length**2 - b * (1 + h) * length + b * r
    return abs(value) / terms if terms > 0 else abs(value)


_root64 = jax.jit(lambda r, h, b: FENE(b).implicit_length(r, h))


@settings(max_examples=100, deadline=None)
@given(
    # 0 or a normal float (XLA on CPU flushes subnormals to zero)
    r=st.one_of(st.just(0.0), st.floats(1e-300, 1e4)),
    h=st.floats(1e-7, 1.0),
    b=st.floats(0.5, 1e4),
)
def test_fene_length_is_the_root_below_q0(r, h, b):
    """The corrector's length solves l (1 + h/(1 - l^2/b)) = R with 0 <= l < sqrt(b): the
    unique root below Q_0 (the left side rises from 0 to infinity on [0, sqrt(b))).  In
    this range the root is at least 1e-12 sqrt(b) below Q_0, so the rounding guard must
    not act.  Checked to a backward error of 1e-13 (an mpmath reference agrees to 4e-16
    on a 49 x 19 grid of R/sqrt(b) in [1e-6, 1e6] and h in [1e-9, 1])."""
    length, guard = _root64(jnp.float64(r), jnp.float64(h), jnp.float64(b))
    length = float(length)
    assert not bool(guard)
    assert 0.0 <= length < math.sqrt(b)
    assert _poly_residual(length, r, h, b) < 1e-13
    # the root lies below the Hookean value R/(1+h) (the FENE factor is >= 1)
    assert length <= r / (1 + h) + 1e-12 * (1 + r)


def test_trisected_cosine_is_the_middle_root():
    """trisected_cosine(x) = cos(arccos(x)/3 - 2 pi/3), the root in [-1/2, 1/2] of
    4y^3 - 3y = x (the Viete step of FENE.implicit_length), against NumPy's float64
    arccos and cos on [-1, 1] and near both ends.  Tolerance: the Chebyshev bound
    4 M rho^-n / (rho - 1) of a degree-n = 18 series in s = sqrt((1-|x|)/2) on
    [0, 1/sqrt 2], whose nearest singularity (s = 1) sets rho = 3.36; M ~ 1: 6e-10."""
    x = np.concatenate(
        [np.linspace(-1, 1, 100_001), 1 - np.logspace(-16, -1, 500), -1 + np.logspace(-16, -1, 500)]
    )
    y = np.asarray(jax.jit(trisected_cosine)(jnp.asarray(x)))
    np.testing.assert_allclose(y, np.cos(np.arccos(x) / 3 - 2 * math.pi / 3), rtol=0, atol=1e-9)
    assert np.all(np.abs(y) <= 0.5 + 1e-9)


def test_fene_length_float32_and_extremes():
    """float32 lengths stay float32 and below Q_0.  Where the exact root is closer to Q_0
    than float32 can resolve (R >> Q_0 with tiny h), the rounding guard returns the
    largest length it allows, and only there."""
    r = jnp.asarray([0.0, 1e-6, 1.0, 7.0, 7.0711, 8.0, 1e3, 1e6], dtype=jnp.float32)
    for h in (2.5e-6, 2.5e-3, 2.5):
        length, guard = FENE(jnp.float32(50.0)).implicit_length(r, jnp.float32(h))
        assert length.dtype == jnp.float32
        assert np.all(np.asarray(length) < np.float32(math.sqrt(50.0)))
        assert np.all(np.asarray(length) >= 0)
        exact, _ = _root64(jnp.asarray(r, jnp.float64), jnp.float64(h), jnp.float64(50.0))
        gap = 1 - np.asarray(exact) / math.sqrt(50.0)
        assert np.all(gap[np.asarray(guard)] < 8 * np.finfo(np.float32).eps)
        ok = ~np.asarray(guard)
        np.testing.assert_allclose(np.asarray(length)[ok], np.asarray(exact)[ok], rtol=2e-6)


def test_fene_length_gradient_is_implicit_function_derivative():
    """d l / d b and d l / d R from autodiff equal central finite differences of the
    float64 root (implicit function theorem, springs.FENE.implicit_length)."""
    f = jax.jit(lambda b, r: FENE(b).implicit_length(r, 0.0025)[0])
    grad = jax.jit(jax.grad(f, argnums=(0, 1)))
    for r in (0.5, 5.0, 7.5, 40.0):  # the three branches of the root
        gb, gr = grad(jnp.float64(50.0), jnp.float64(r))
        eps = 1e-5
        fd_b = (f(50.0 + eps, r) - f(50.0 - eps, r)) / (2 * eps)
        fd_r = (f(50.0, r + eps) - f(50.0, r - eps)) / (2 * eps)
        np.testing.assert_allclose(gb, fd_b, rtol=1e-6, atol=1e-12)
        np.testing.assert_allclose(gr, fd_r, rtol=1e-6, atol=1e-12)


def _linear_map(kappa, dt):
    """(A, B) with Q_{n+1} = A Q_n + B dW_n for a Hookean step, read off ottinger_step."""
    eye = jnp.eye(3, dtype=jnp.float64)
    zero = jnp.zeros(3, dtype=jnp.float64)
    step = lambda q, w: ottinger_step(q, w, kappa, Hookean(), dt)[0]  # noqa: E731
    a = jnp.stack([step(e, zero) for e in eye], axis=1)
    b = jnp.stack([step(zero, e) for e in eye], axis=1)
    return np.asarray(a), np.asarray(b)


@pytest.mark.parametrize("dt", [0.001, 0.05, 0.5])
def test_hookean_scheme_matches_formula_and_is_exact_at_rest(dt):
    """For a Hookean spring the scheme is linear, Q' = A Q + B dW, with (module doc)
    A = [(1-h) I + dt kappa + dt^2 kappa (kappa - I/2)/2] / (1+h), B = (I + dt kappa/2)/(1+h),
    h = dt/4.  At rest A^2 + dt B^2 = 1: the stationary variance <Q_i^2> = dt B^2/(1-A^2)
    equals the exact value 1 (equipartition) for every dt."""
    h = dt / 4
    kappa = np.asarray(velocity_gradient("shear", 3.0))
    a, b = _linear_map(jnp.asarray(kappa), dt)
    eye = np.eye(3)
    a_ref = ((1 - h) * eye + dt * kappa + 0.5 * dt**2 * kappa @ (kappa - 0.5 * eye)) / (1 + h)
    np.testing.assert_allclose(a, a_ref, atol=1e-15)
    np.testing.assert_allclose(b, (eye + 0.5 * dt * kappa) / (1 + h), atol=1e-15)
    a0, b0 = _linear_map(jnp.zeros((3, 3), jnp.float64), dt)
    np.testing.assert_allclose(np.diag(a0) ** 2 + dt * np.diag(b0) ** 2, 1.0, rtol=1e-14)


def test_vmap_over_rates_and_chunking_equal_separate_runs_and_single_steps():
    """Invariants: (i) a run vmapped over three shear rates equals three separate runs;
    (ii) counter-based noise: 20 steps as 4 lax.scan chunks of 5 equal 20 single
    step_fn calls (a trajectory does not depend on how its steps are grouped)."""
    spring, dt, key = FENE(50.0), 0.01, jax.random.key(3)
    q0 = 0.5 * jax.random.normal(jax.random.key(1), (16, 3), dtype=jnp.float64)
    state = state_from_connectors(q0, spring)
    kappas = velocity_gradient("shear", jnp.asarray([0.5, 5.0, 50.0]))
    run = lambda k: simulate(key, state, k, spring, dt, n_samples=4, sample_every=5)  # noqa: E731
    batched, samples = jax.jit(jax.vmap(run))(kappas)
    run_one = jax.jit(run)
    for i in range(3):
        single, single_samples = run_one(kappas[i])
        np.testing.assert_allclose(batched.connector[i], single.connector, rtol=1e-12)
        np.testing.assert_allclose(samples["fqq"][i], single_samples["fqq"], rtol=1e-12)
    _, step_fn = predictor_corrector(spring, dt)
    step_fn = jax.jit(step_fn)
    c = state
    for _ in range(20):  # a test-side loop over 20 calls, to compare with lax.scan
        c = step_fn(key, c, kappas[2])
    np.testing.assert_allclose(single.connector, c.connector, rtol=1e-13, atol=1e-13)
    assert int(single.step) == 20


def test_float32_run_stays_float32_and_below_q0():
    """float32 in, float32 throughout, three-point noise; in planar elongation at
    De = 1000 (De dt = 0.1, stretched to within 0.1 % of Q_0) no dumbbell reaches
    Q >= Q_0 at any step and the rounding guard never acts (must show 3, float32)."""
    spring = FENE(50.0)
    q0 = jax.random.normal(jax.random.key(0), (256, 3), dtype=jnp.float32)
    state = state_from_connectors(q0, spring)
    kappa = velocity_gradient("planar_elongation", 1000.0, dtype=jnp.float32)
    final, samples = jax.jit(
        lambda s: simulate(
            jax.random.key(1),
            s,
            kappa,
            spring,
            1e-4,
            n_samples=20,
            sample_every=50,
            noise="three_point",
        )  # fmt: skip
    )(state)
    assert final.connector.dtype == jnp.float32
    assert samples["fqq"].dtype == jnp.float32
    assert np.all(np.isfinite(final.connector))
    assert float(jnp.max(final.max_extension2)) < 1
    assert int(jnp.sum(final.guard_hits)) == 0
    assert float(samples["q2"][-1]) / 50.0 > 0.99  # stretched


def test_three_point_increments_have_gaussian_moments():
    """Three-point increments sqrt(3 dt){-1,0,1} w.p. {1/6,2/3,1/6} (Kloeden & Platen
    ch. 14): frequencies within 4 binomial standard errors; exact moments E z^2 = dt,
    E z^4 = 3 dt^2 follow from the frequencies."""
    dt, n = 0.04, 200_000
    z = np.asarray(wiener_increments(jax.random.key(5), 3, n, dt, jnp.float64, "three_point"))
    s = z / math.sqrt(3 * dt)
    np.testing.assert_allclose(np.abs(s[np.abs(s) > 0.5]), 1.0, rtol=1e-14)
    for value, p in ((-1, 1 / 6), (0, 2 / 3), (1, 1 / 6)):
        freq = np.mean(np.round(s) == value, axis=0)  # per component
        assert np.all(np.abs(freq - p) < 4 * math.sqrt(p * (1 - p) / n))
    # components are independent: the joint frequency of (+1, +1) is 1/36
    joint = np.mean((np.round(s[:, 0]) == 1) & (np.round(s[:, 1]) == 1))
    assert abs(joint - 1 / 36) < 4 * math.sqrt((1 / 36) * (35 / 36) / n)


@pytest.mark.parametrize("dtype", [jnp.float64, jnp.float32])
def test_gaussian_increments_have_exact_moments(dtype):
    """Counter-based Gaussian increments (Box–Muller on jaxdpd.engine.noise bits) against
    the exact moments of N(0, dt): E z = 0, E z^2 = dt, E z^4 = 3 dt^2, E z_a z_b = 0,
    pooled over the three components of n dumbbells; tolerance 4 standard errors of
    the sample mean (Var z = dt, Var z^2 = 2 dt^2, Var z^4 = 96 dt^4, Var z_a z_b = dt^2)."""
    dt, n = 0.04, 200_000
    z = np.asarray(wiener_increments(jax.random.key(5), 3, n, dt, dtype), np.float64)
    assert z.shape == (n, 3) and np.all(np.isfinite(z))
    count = z.size
    assert abs(z.mean()) < 4 * math.sqrt(dt / count)
    assert abs(np.mean(z**2) - dt) < 4 * math.sqrt(2 / count) * dt
    assert abs(np.mean(z**4) - 3 * dt**2) < 4 * math.sqrt(96 / count) * dt**2
    for a, b in ((0, 1), (0, 2), (1, 2)):
        assert abs(np.mean(z[:, a] * z[:, b])) < 4 * dt / math.sqrt(n)
    # each component alone has the variance (the Box–Muller radius and angle streams)
    assert np.all(np.abs(np.mean(z**2, axis=0) - dt) < 4 * math.sqrt(2 / n) * dt)


def test_float64_logarithm_of_the_box_muller_radius():
    """The float64 ln u of the Gaussian increments (frexp and a truncated atanh series,
    truncation < 1e-17) equals NumPy's log to a few units of round-off (relative 1e-15)
    on the uniforms the 32-bit counters give, their extremes included."""
    bits = np.random.default_rng(0).integers(0, 2**32, 100_000).astype(np.float64)
    u = np.concatenate([bits, [0.0, 2.0**32 - 1, 2.0**31, 0.7071067811865476 * 2**32]]) + 0.5
    u = u * 2.0**-32
    np.testing.assert_allclose(
        np.asarray(jax.jit(_log_unit)(jnp.asarray(u))), np.log(u), rtol=1e-15
    )


def test_increments_of_other_keys_and_steps_are_uncorrelated():
    """Streams keyed by (key, step): different keys (a vmapped ensemble of keys) and
    consecutive steps give uncorrelated increments (correlation within 4/sqrt(3n));
    the same key and step give the same increments (bit for bit in the same program,
    to round-off under vmap, where XLA may contract multiply-adds differently)."""
    n = 50_000
    draw = jax.jit(lambda k, step: wiener_increments(k, step, n, 1.0, jnp.float64).ravel())
    keys = jax.random.split(jax.random.key(9), 2)
    z = np.asarray(jax.vmap(draw)(keys, jnp.asarray([4, 4])))
    later = np.asarray(draw(keys[0], 5))
    for other in (z[1], later):
        assert abs(np.corrcoef(z[0], other)[0, 1]) < 4 / math.sqrt(3 * n)
    first = np.asarray(draw(keys[0], 4))
    np.testing.assert_array_equal(first, np.asarray(draw(keys[0], 4)))
    np.testing.assert_allclose(z[0], first, rtol=1e-14, atol=1e-15)


_sample = jax.jit(lambda key, b: equilibrium_state(key, FENE(b), 100_000).connector)


@pytest.mark.parametrize("b", [5.0, 50.0])
def test_fene_equilibrium_sampler_moments(b):
    """Q^2/b ~ Beta(3/2, b/2 + 1) at equilibrium: E[Q^2]/b = 3/(b+5) (thesis eq. 4.8) and
    E[Q^4]/b^2 = a(a+1)/((a+c)(a+c+1)), a = 3/2, c = b/2 + 1.  i.i.d. samples: tolerance
    4 standard errors of the sample mean."""
    n = 100_000
    q = _sample(jax.random.key(11), jnp.float64(b))
    u = np.asarray(jnp.sum(q * q, axis=-1)) / b
    a, c = 1.5, b / 2 + 1
    assert u.max() < 1
    assert abs(u.mean() - 3 / (b + 5)) < 4 * u.std() / math.sqrt(n)
    m2 = a * (a + 1) / ((a + c) * (a + c + 1))
    assert abs(np.mean(u**2) - m2) < 4 * np.std(u**2) / math.sqrt(n)
    # isotropy: the mean connector vanishes
    assert np.all(np.abs(np.asarray(q.mean(axis=0))) < 4 * np.asarray(q.std(axis=0)) / math.sqrt(n))
