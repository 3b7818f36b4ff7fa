"""Bias of the multiple-tau MSD: block means (the scheme before issue 29) against the
subsampling the correlator now uses in MSD mode, on signals with known MSDs.

Signals (independent channels, unit-variance kicks): a random walk, MSD(d) = d (as the
bead and centre-of-mass MSDs g1, g3), and an Ornstein–Uhlenbeck (AR(1)) signal with
correlation time tau, MSD(d) = 2 (1 - exp(-d/tau)) (as g2).  For each lag the table
gives the relative deviation from the formula of: the correlator (``mode="msd"``,
16 points per level, m = 2), the direct estimator on block means of the level's width
(what the correlator computed before), and the exact all-origins FFT MSD; errors are
standard errors of the channel mean.

    python benchmarks/correlator_bias.py [--channels 512] [--samples 8192] [--tau 50]

Writes benchmarks/results/correlator_bias.json.
"""

import argparse

import jax
import jax.numpy as jnp
import numpy as np
from _common import print_table, write_json

from jaxdpd.analysis.dynamics import time_msd
from jaxdpd.observables import correlator

POINTS, AVERAGING = 16, 2
REPORTED_LAGS = (16, 32, 64, 128, 256, 512, 1024)


def random_walk(rng, samples, channels):
    return np.cumsum(rng.normal(size=(samples, channels)), axis=0)


def ornstein_uhlenbeck(rng, samples, channels, tau):
    rho = np.exp(-1 / tau)
    signal = np.empty((samples, channels))
    signal[0] = rng.normal(size=channels)
    kicks = rng.normal(size=(samples, channels)) * np.sqrt(1 - rho**2)
    for t in range(1, samples):
        signal[t] = rho * signal[t - 1] + kicks[t]
    return signal


def block_mean_msd(series, lag):
    """Direct MSD of the means of blocks of the width the multiple-tau level of `lag`
    uses (level l serves lags j 2^l, j = 8 .. 15), per channel."""
    width = 1
    while lag // width >= POINTS:
        width *= AVERAGING
    blocks = len(series) // width
    means = series[: blocks * width].reshape(blocks, width, -1).mean(axis=1)
    j = lag // width
    return ((means[j:] - means[:-j]) ** 2).mean(axis=0)


def relative(values, exact):
    deviation = values / exact - 1
    return float(deviation.mean()), float(deviation.std(ddof=1) / np.sqrt(deviation.size))


def measure(name, series, exact_msd, levels):
    state = correlator.init(series.shape[1:], levels, POINTS, AVERAGING, mode="msd")
    lags, values = correlator.result(jax.jit(correlator.update_many)(state, jnp.asarray(series)))
    values = np.asarray(values)
    fft = np.asarray(time_msd(jnp.asarray(series)))
    rows = []
    for lag in REPORTED_LAGS:
        exact = exact_msd(lag)
        index = int(np.flatnonzero(lags == lag)[0])
        row = {"signal": name, "lag": lag}
        for column, estimate in (
            ("correlator", values[index]),
            ("block_means", block_mean_msd(series, lag)),
            ("fft", fft[lag]),
        ):
            mean, error = relative(estimate, exact)
            row[column] = f"{100 * mean:+.2f} ± {100 * error:.2f} %"
            row[column + "_relative"] = (mean, error)
        rows.append(row)
    return rows


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--channels", type=int, default=512)
    parser.add_argument("--samples", type=int, default=8192)
    parser.add_argument("--tau", type=float, default=50.0)
    args = parser.parse_args()
    jax.config.update("jax_enable_x64", True)
    rng = np.random.default_rng(2029)
    levels = int(np.log2(max(REPORTED_LAGS) / (POINTS // 2))) + 1
    rows = measure(
        "random walk",
        random_walk(rng, args.samples, args.channels),
        lambda d: float(d),
        levels,
    )
    rows += measure(
        f"OU tau={args.tau:g}",
        ornstein_uhlenbeck(rng, args.samples, args.channels, args.tau),
        lambda d: 2 * (1 - np.exp(-d / args.tau)),
        levels,
    )
    print_table(["signal", "lag", "correlator", "block_means", "fft"], rows)
    path = write_json(
        "correlator_bias",
        {
            "arguments": vars(args),
            "rows": [
                {k: v for k, v in r.items() if not isinstance(v, str) or k == "signal"}
                for r in rows
            ],
        },
    )
    print(f"wrote {path}")


if __name__ == "__main__":
    main()
