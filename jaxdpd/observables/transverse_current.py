"""Shear viscosity at equilibrium from the decay of transverse momentum fluctuations.

The transverse momentum current of wave vector k = k e_b,

    j_a(k, t) = Σ_i m_i v_{i,a}(t) exp(i k r_{i,b}),     a ≠ b,

obeys the linearised Navier–Stokes equation ∂_t j = −ν k² j at small k, so its
equilibrium autocorrelation decays as

    C(k, t) = Re ⟨j_a(k, t) j_a(k, 0)*⟩ = C(k, 0) exp(−ν k² t),   ν = η / ϱ

(kinematic viscosity ν, mass density ϱ; Hansen & McDonald, Theory of Simple Liquids,
3rd ed. (2006), §8.4, eqs. 8.4.6–8.4.9).  In a periodic box k = 2πn/L_b; the six
ordered pairs (a, b), a ≠ b, of a cubic box are equivalent and averaged.

Errors and their control:
- finite k: the decay rate is ν(k) k² with ν(k) = ν + O(k²) (generalised
  hydrodynamics; for MPCD the kinetic part also carries O((kλ)²) terms, λ = h √(kT/m)
  the mean free path).  `kinematic_viscosity` measures ν(k) at the smallest modes
  n = 1, 2, ... and extrapolates linearly in k² to k = 0;
- finite size: in a periodic box the smallest k is 2π/L; apart from fixing the
  allowed k there is no finite-size correction to ν at this order;
- statistics: the decay rate is fitted to the correlation averaged over the whole
  run; the run is cut into blocks much longer than 1/(ν k²) and the delete-one-block
  jackknife gives the standard errors.
"""

import jax.numpy as jnp
import numpy as np

from jaxdpd.analysis.dynamics import time_autocorrelation
from jaxdpd.observables.component import Observable, Setting
from jaxdpd.trigonometry import sincos_turns
from jaxdpd.validation import SceneError

# (velocity component a, wave-vector axis b), a ≠ b.
TRANSVERSE_PAIRS = ((0, 1), (0, 2), (1, 0), (1, 2), (2, 0), (2, 1))


def _phase_factors(coordinate, length: float, n_modes: int):
    """cos(k_n x) and sin(k_n x), k_n = 2πn/L, n = 1 .. n_modes, as (n_modes, N) each,
    by the angle-addition recurrence from the n = 1 values."""
    sin_1, cos_1 = sincos_turns(coordinate * (1.0 / length))
    cosines, sines = [cos_1], [sin_1]
    for _ in range(n_modes - 1):
        cos_n, sin_n = cosines[-1], sines[-1]
        cosines.append(cos_n * cos_1 - sin_n * sin_1)
        sines.append(sin_n * cos_1 + cos_n * sin_1)
    return jnp.stack(cosines), jnp.stack(sines)


def transverse_currents(positions, velocities, masses, lengths, n_modes: int):
    """The transverse currents j_a(2πn/L_b e_b) of one configuration.

    Args:
        positions: (N, 3).
        velocities: (N, 3).
        masses: (N,) masses or None (unit masses).
        lengths: box edges (L_x, L_y, L_z) (static floats).
        n_modes: modes n = 1 .. n_modes.
    Returns:
        (n_modes, 6, 2): real and imaginary parts of j, pairs in TRANSVERSE_PAIRS order.
    """
    momenta = velocities if masses is None else masses[:, None] * velocities
    factors = [_phase_factors(positions[:, b], lengths[b], n_modes) for b in range(3)]
    columns = []
    for a, b in TRANSVERSE_PAIRS:
        cosines, sines = factors[b]
        columns.append(jnp.stack([cosines @ momenta[:, a], sines @ momenta[:, a]], axis=-1))
    return jnp.stack(columns, axis=1)


def transverse_current_correlation(currents):
    """C(k_n, t) over all time origins, averaged over the six pairs.

    Args:
        currents: (T, n_modes, 6, 2) samples at equal time intervals.
    Returns:
        (T, n_modes): Re ⟨j(t0 + t) j(t0)*⟩ at lags t = 0 .. T − 1 (sample units).
    """
    correlation = np.asarray(time_autocorrelation(jnp.asarray(currents)))
    return correlation.sum(axis=-1).mean(axis=-1)


def fit_window(correlation, window: float = 1.5) -> int:
    """The number of lags K such that C/C(0) stays above exp(−window) for lags < K.

    Args:
        correlation: (T,) correlation at lags 0 .. T − 1 (the best estimate: the whole
            run, so that every block is fitted over the same lags).
        window: decay (in e-folds) covered by the fit.
    """
    ratio = np.asarray(correlation) / correlation[0]
    below = np.nonzero(ratio < np.exp(-window))[0]
    return int(below[0]) if below.size else len(ratio)


def decay_rate(correlation, interval: float, lags: int):
    """Exponential decay rate of a correlation: the least-squares slope of −ln(C/C(0))
    against time over lags 1 .. lags − 1 (the amplitude is free, so a fast initial
    drop of non-hydrodynamic modes does not bias the rate).

    Args:
        correlation: (T,) correlation at lags 0 .. T − 1.
        interval: time between samples.
        lags: fit lags 1 .. lags − 1 (`fit_window`).
    Returns:
        The rate Γ (1/time); NaN when fewer than two lags are given or C turns
        negative within them (too noisy).
    """
    ratio = np.asarray(correlation)[1:lags] / correlation[0]
    if len(ratio) < 2 or np.any(ratio <= 0):
        return float("nan")
    times = np.arange(1, lags) * interval
    logs = np.log(ratio)
    centred = times - times.mean()
    return float(-(centred @ (logs - logs.mean())) / (centred @ centred))


def _jackknife_rates(correlations, interval: float, window: float):
    """Decay rates of the block-mean correlation and their jackknife standard errors.

    Fitting the mean over all blocks (not each block) keeps the bias of the
    logarithm of a noisy ratio at the 1/n_blocks level; the delete-one-block
    jackknife (Efron & Tibshirani, An Introduction to the Bootstrap (1993), ch. 11)
    gives the standard error, including that of the k → 0 extrapolation.

    Args:
        correlations: (n_blocks, T, n_modes) correlation per block.
        interval: time between samples.
        window: e-folds of decay covered by the fit.
    Returns:
        (rates (n_modes,), leave-one-out rates (n_blocks, n_modes)).
    """
    n_blocks, _, n_modes = correlations.shape
    mean = correlations.mean(axis=0)
    lags = [fit_window(mean[:, mode], window) for mode in range(n_modes)]

    def rates(correlation):
        return np.array([decay_rate(correlation[:, m], interval, lags[m]) for m in range(n_modes)])

    total = correlations.sum(axis=0)
    left_out = np.stack([rates((total - block) / (n_blocks - 1)) for block in correlations])
    return rates(mean), left_out


def _viscosities(rates, left_out, k_squared) -> dict:
    """ν(k) = Γ/k² per mode and its straight-line k → 0 extrapolation in k², with
    jackknife standard errors.

    Args:
        rates: (n_modes,) decay rates Γ of the mean correlation.
        left_out: (n_blocks, n_modes) rates with one block left out.
        k_squared: (n_modes,) k².
    """
    n_blocks = left_out.shape[0]

    def spread(values):
        return np.sqrt((n_blocks - 1) / n_blocks * np.sum((values - values.mean(0)) ** 2, axis=0))

    result = {
        "k_squared": k_squared,
        "per_mode": rates / k_squared,
        "per_mode_error": spread(left_out / k_squared),
    }
    if len(k_squared) >= 2:
        design = np.stack([np.ones(len(k_squared)), k_squared], axis=1)

        def intercept(values):
            return np.linalg.lstsq(design, np.asarray(values).T, rcond=None)[0][0]

        result["extrapolated"] = float(intercept(rates / k_squared))
        result["extrapolated_error"] = float(spread(intercept(left_out / k_squared)))
    return result


def kinematic_viscosity(
    currents, interval: float, length: float, n_blocks: int = 10, window: float = 1.0
):
    """ν from equilibrium transverse-current samples, per mode and extrapolated to k → 0.

    Args:
        currents: (T, n_modes, 6, 2) from `transverse_currents`, one sample every
            `interval` (a cubic box of edge `length`).
        interval: time between samples.
        length: box edge L.
        n_blocks: blocks for the jackknife errors (each much longer than 1/(νk²)).
        window: e-folds of decay covered by the fit (`fit_window` of the mean
            correlation).
    Returns:
        dict with "k_squared" (n_modes,), "per_mode" (n_modes,) ν(k_n) = Γ_n/k_n² and
        "per_mode_error"; with two or more modes "extrapolated" and
        "extrapolated_error": ν at k = 0 from a straight line in k² through the modes.
    """
    samples = np.asarray(currents)
    n_modes = samples.shape[1]
    k_squared = (2 * np.pi * np.arange(1, n_modes + 1) / length) ** 2
    block_length = samples.shape[0] // n_blocks
    blocks = samples[: n_blocks * block_length].reshape(n_blocks, block_length, *samples.shape[1:])
    correlations = np.stack([transverse_current_correlation(block) for block in blocks])
    return _viscosities(*_jackknife_rates(correlations, interval, window), k_squared)


class TransverseCurrent(Observable):
    """Per-step transverse momentum currents j(k, t) at k = 2πn/L, n = 1 ..
    output.current_modes (cubic boxes)."""

    name = "transverse_current"
    decomposes = True
    settings = (Setting("current_modes", 3, minimum=1, integer=True),)
    units = {"transverse_current": "m r_c/τ"}  # Σ_i m_i v_ia e^{ik r_ib}: a momentum

    def check(self, scene):
        lengths = scene.box.lengths
        if len(set(lengths)) != 1:
            raise SceneError(
                "output.observables",
                "'transverse_current' averages the six transverse pairs of a cubic box; "
                f"box.lengths = {list(lengths)} is not cubic",
            )

    def memory(self, scene, itemsize):
        return {"output.current_modes": 2 * scene.run.chunk * scene.output.current_modes * itemsize}

    def sampler(self, context):
        box, masses, modes = context.box, context.masses, context.scene.output.current_modes

        def sample(previous, state):
            currents = transverse_currents(
                state.positions, state.velocities, masses, box.lengths, modes
            )
            return state, {"transverse_current": currents}

        return sample

    def domain_sampler(self, context):
        """j summed over each device's owned rows (weights 1, others 0: unit masses),
        then over the devices."""
        lengths, modes = context.box.lengths, context.scene.output.current_modes

        def sample(ownership, state):
            weights = ownership.weights(state.velocities.dtype)
            currents = transverse_currents(
                state.positions, state.velocities, weights, lengths, modes
            )
            return {"transverse_current": ownership.across_devices(currents)}

        return sample
