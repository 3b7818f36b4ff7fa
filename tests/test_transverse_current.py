"""The transverse-current observable and its viscosity estimator; the polynomial
sine/cosine they use."""

import math

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from jaxdpd.observables.transverse_current import (
    TRANSVERSE_PAIRS,
    kinematic_viscosity,
    transverse_currents,
)
from jaxdpd.trigonometry import sincos_turns


@pytest.mark.parametrize(("dtype", "tolerance"), [(jnp.float64, 4e-15), (jnp.float32, 3e-7)])
def test_sincos_turns_matches_numpy(dtype, tolerance):
    turns = jnp.asarray(np.linspace(-3.0, 3.0, 100_001), dtype)
    sine, cosine = jax.jit(sincos_turns)(turns)
    assert sine.dtype == dtype and cosine.dtype == dtype
    angle = 2 * np.pi * np.asarray(turns, np.float64)
    np.testing.assert_allclose(np.asarray(sine, np.float64), np.sin(angle), rtol=0, atol=tolerance)
    np.testing.assert_allclose(
        np.asarray(cosine, np.float64), np.cos(angle), rtol=0, atol=tolerance
    )


def test_transverse_currents_match_the_definition():
    """j_a(k e_b) = Σ_i m_i v_ia exp(i k r_ib), k = 2πn/L_b, by NumPy's complex exp."""
    rng = np.random.default_rng(2)
    lengths = (4.0, 5.0, 6.0)
    positions = rng.uniform(size=(300, 3)) * np.asarray(lengths)
    velocities = rng.normal(size=(300, 3))
    masses = rng.uniform(1, 3, 300)
    currents = np.asarray(
        transverse_currents(
            jnp.asarray(positions), jnp.asarray(velocities), jnp.asarray(masses), lengths, 3
        )
    )
    for pair, (a, b) in enumerate(TRANSVERSE_PAIRS):
        for n in range(1, 4):
            expected = np.sum(
                masses * velocities[:, a] * np.exp(2j * np.pi * n * positions[:, b] / lengths[b])
            )
            np.testing.assert_allclose(
                currents[n - 1, pair], [expected.real, expected.imag], atol=1e-11
            )


def test_viscosity_estimator_recovers_a_known_decay():
    """Synthetic currents: independent AR(1) series x(t+1) = λ x(t) + √(1 − λ²) ξ with
    λ_n = exp(−ν k_n² Δt) (exact correlation λ^t) for ν = 0.8, L = 10, Δt = 0.1, plus
    a k⁴ term in the rate: ν(k) = ν (1 − 0.05 k²).  The estimator must recover each
    ν(k_n) and the k → 0 extrapolation ν within 4 jackknife standard errors — which
    also checks that those errors are not too small."""
    nu, length, interval, steps = 0.8, 10.0, 0.1, 40_000
    k_squared = (2 * np.pi * np.arange(1, 4) / length) ** 2
    nu_k = nu * (1 - 0.05 * k_squared)
    decay = np.exp(-nu_k * k_squared * interval)
    rng = np.random.default_rng(5)
    noise = rng.normal(size=(steps, 3, 6, 2))
    series = np.empty_like(noise)
    series[0] = noise[0]
    factor = decay[:, None, None]
    kick = np.sqrt(1 - decay**2)[:, None, None]
    for t in range(1, steps):
        series[t] = factor * series[t - 1] + kick * noise[t]
    result = kinematic_viscosity(series, interval, length, n_blocks=10)
    np.testing.assert_allclose(result["k_squared"], k_squared)
    deviation = np.abs(result["per_mode"] - nu_k) / result["per_mode_error"]
    assert np.all(deviation < 4), (result["per_mode"], nu_k, result["per_mode_error"])
    assert np.all(result["per_mode_error"] < 0.03 * nu_k)
    assert abs(result["extrapolated"] - nu) < 4 * result["extrapolated_error"], result
    assert math.isfinite(result["extrapolated_error"]) and result["extrapolated_error"] < 0.05 * nu
