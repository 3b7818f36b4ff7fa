"""MSDs g1/g2/g3, positional autocorrelation, CM VACF and D_CM.

Exact identities against brute force, and statistics against an exactly sampled Rouse
chain: with Hookean springs H, bead friction zeta and k_BT = 1 the modes
X_p = (1/N) sum_n r_n cos(p pi (n - 1/2)/N) of a free-draining Gaussian chain are
independent Ornstein-Uhlenbeck processes, relaxation time tau_p = zeta/(4 H sin^2(p pi/2N))
and per-component variance <X_p^2>/3 = l^2/(24 N sin^2(p pi/2N)), l^2 = 3/H; X_0 (the
centre of mass) diffuses with D = 1/(N zeta) (Doi & Edwards 1986, sec. 4.1-4.2, for the
discrete chain).  The OU processes are advanced with their exact transition law, so the
trajectory has no time-step error.
"""

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from jaxdpd.analysis import conformation, dynamics, fits
from jaxdpd.observables import correlator

N_CHAINS, N_BEADS, N_TIMES, DT = 100, 8, 1024, 0.1
SPRING, FRICTION = 3.0, 1.0  # l^2 = 3 k_BT / H = 1
TOLERANCE_SIGMAS = 4.0


def rouse_trajectory(seed):
    """(T, n_chains, N, 3) exact Rouse-chain trajectory in equilibrium."""
    rng = np.random.default_rng(seed)
    p = np.arange(1, N_BEADS)
    sin2 = np.sin(p * np.pi / (2 * N_BEADS)) ** 2
    tau = FRICTION / (4 * SPRING * sin2)
    std = np.sqrt(conformation.gaussian_chain_rouse_amplitudes(N_BEADS, 3 / SPRING) / 3)
    decay = np.exp(-DT / tau)[:, None]
    modes = np.empty((N_TIMES, N_CHAINS, N_BEADS, 3))
    modes[0, :, 1:] = rng.normal(size=(N_CHAINS, N_BEADS - 1, 3)) * std[:, None]
    modes[0, :, 0] = 0.0
    kick = std[:, None] * np.sqrt(1 - decay**2)
    diffusion = 1 / (N_BEADS * FRICTION)
    for t in range(1, N_TIMES):
        modes[t, :, 1:] = decay * modes[t - 1, :, 1:] + kick * rng.normal(
            size=(N_CHAINS, N_BEADS - 1, 3)
        )
        modes[t, :, 0] = modes[t - 1, :, 0] + np.sqrt(2 * diffusion * DT) * rng.normal(
            size=(N_CHAINS, 3)
        )
    n = np.arange(1, N_BEADS + 1)
    basis = np.cos(p[:, None] * np.pi * (n[None, :] - 0.5) / N_BEADS)
    return modes[..., :1, :] + 2 * np.einsum("pn,tcpd->tcnd", basis, modes[..., 1:, :]), tau[0]


@pytest.fixture(scope="module")
def rouse():
    return rouse_trajectory(seed=21)


def test_fft_correlations_equal_brute_force():
    """time_msd / time_autocorrelation against the direct average over origins, every lag,
    float64 to round-off and float32 to its precision."""
    rng = np.random.default_rng(0)
    # (64, 10, 3): the shape of the centres of mass in the next tests (shared compiles).
    series = np.cumsum(rng.normal(size=(64, 10, 3)), axis=0)
    fft_msd, fft_acf = dynamics.time_msd(series), dynamics.time_autocorrelation(series)
    for lag in range(64):
        msd = ((series[lag:] - series[: 64 - lag]) ** 2).mean(axis=0)
        acf = (series[lag:] * series[: 64 - lag]).mean(axis=0)
        np.testing.assert_allclose(fft_msd[lag], msd, rtol=1e-10, atol=1e-10)
        np.testing.assert_allclose(fft_acf[lag], acf, rtol=1e-10, atol=1e-9)
    msd32 = dynamics.time_msd(series.astype(np.float32))
    assert msd32.dtype == jnp.float32
    np.testing.assert_allclose(msd32, fft_msd, rtol=1e-3, atol=1e-2)


def test_msd_definitions_and_identities(rouse):
    """Rigid translation: g2 = 0 and g1 = g3.  Positional autocorrelation equals the
    amplitude-weighted Rouse-mode autocorrelation sum_p <X_p(t).X_p(0)> / sum_p <X_p^2>
    exactly (module docstring); CM VACF equals the brute-force one."""
    trajectory, _ = rouse
    short = trajectory[:64, :10]
    shift = np.cumsum(np.random.default_rng(1).normal(size=(64, 1, 1, 3)), axis=0)
    rigid = short[:1] + shift
    np.testing.assert_allclose(dynamics.relative_bead_msd(rigid), 0, atol=1e-10)
    np.testing.assert_allclose(
        dynamics.bead_msd(rigid), dynamics.center_of_mass_msd(rigid), rtol=1e-10, atol=1e-12
    )

    correlation, error = dynamics.positional_autocorrelation(short)
    modes = np.asarray(conformation.rouse_modes(short))[:, :, 1:]
    mode_correlation = np.array(
        [np.sum(modes[lag:] * modes[: 64 - lag]) / (64 - lag) for lag in range(64)]
    )
    np.testing.assert_allclose(correlation, mode_correlation / mode_correlation[0], rtol=1e-9)
    assert error[0] == pytest.approx(0, abs=1e-12) and np.all(np.asarray(error[1:]) > 0)

    velocities = short / DT  # any array of the right shape serves for the identity
    vacf = np.asarray(dynamics.center_of_mass_vacf(velocities))
    center_velocity = velocities.mean(axis=2)
    for lag in (0, 1, 7):
        brute = (center_velocity[lag:] * center_velocity[: 64 - lag]).sum(axis=-1).mean(axis=0)
        np.testing.assert_allclose(vacf[lag], brute, rtol=1e-9)


def test_rouse_chain_positional_autocorrelation_and_diffusion(rouse):
    """C(t) of the exact Rouse trajectory equals the Rouse-Zimm model with h* = 0 and the
    exact tau_1 (fits.rouse_zimm_correlation) within 4 jackknife errors up to 3 tau_1; the
    CM diffusion coefficient from the g3 slope equals 1/(N zeta) within 4 block errors."""
    trajectory, tau_1 = rouse
    correlation, error = dynamics.positional_autocorrelation(jnp.asarray(trajectory))
    times = np.arange(N_TIMES) * DT
    window = (times > 0) & (times <= 3 * tau_1)
    model = fits.rouse_zimm_correlation(times[window], N_BEADS, tau_1, 0.0)
    z = (np.asarray(correlation)[window] - model) / np.asarray(error)[window]
    assert np.all(np.abs(z) < TOLERANCE_SIGMAS), np.abs(z).max()

    g3 = np.asarray(dynamics.center_of_mass_msd(jnp.asarray(trajectory)))
    lags = slice(1, N_TIMES // 4)  # long-time lags with many origins
    d, d_error = dynamics.diffusion_coefficient(times[lags], g3[lags], fit_from=5 * tau_1)
    assert abs(d - 1 / (N_BEADS * FRICTION)) < TOLERANCE_SIGMAS * d_error
    assert d_error < 0.2 * d


def test_on_device_correlator_matches_stored_msds(rouse):
    """displacement_samples through the multiple-tau correlator (MSD mode) reproduce
    g1, g2, g3 from the stored trajectory exactly at the level-0 lags."""
    trajectory, _ = rouse
    short = jnp.asarray(trajectory[:64, :10])  # shapes shared with the identities test
    samples = jax.vmap(dynamics.displacement_samples)(short)
    stored = {
        "g1": dynamics.bead_msd(short),
        "g2": dynamics.relative_bead_msd(short),
        "g3": dynamics.center_of_mass_msd(short),
    }
    update_many = jax.jit(correlator.update_many)
    for name, series in samples.items():
        state = correlator.init(series.shape[1:], 3, 8, 2, mode="msd")
        lags, values = correlator.result(update_many(state, series))
        on_device = dynamics.average_over_elements(values[:8])
        np.testing.assert_allclose(
            on_device, np.asarray(stored[name]).mean(axis=1)[lags[:8]], rtol=1e-10, atol=1e-12
        )


def test_bad_arguments():
    with pytest.raises(ValueError, match="at least 2 samples"):
        dynamics.diffusion_coefficient(np.arange(5.0), np.ones((5, 1)), fit_from=1.0)
    with pytest.raises(ValueError, match="fit_from"):
        dynamics.diffusion_coefficient(np.arange(5.0), np.ones((5, 3)), fit_from=10.0)
    with pytest.raises(ValueError, match="trajectory must have shape"):
        dynamics.bead_msd(np.zeros((10, 4, 3)))
    with pytest.raises(ValueError, match="at least 2 times"):
        dynamics.time_msd(np.zeros((1, 3)))
