"""Shear viscosity of a fluid at rest from its stress fluctuations (Green–Kubo).

    η = V/(k_BT) ∫_0^∞ ⟨P_xy(t) P_xy(0)⟩ dt

(Allen & Tildesley, *Computer Simulation of Liquids*, 2nd ed. (2017), §2.7).  In an
isotropic fluid the five independent components of the traceless symmetric stress,
P_xy, P_xz, P_yz, (P_xx − P_yy)/2 and (P_yy − P_zz)/2, have the same autocorrelation
function (Daivis & Evans, J. Chem. Phys. 100, 541 (1994)); they are averaged.  By
linear response this is the viscosity that a weak homogeneous flow of any kind
measures in the same periodic box: η = −P_xy/γ̇ in shear, η̄1/4 and η̄2/2 in planar
elongation (jaxdpd.observables.elongation).
"""

import numpy as np

from jaxdpd.observables.dynamics import time_autocorrelation


def traceless_components(pressure_tensor):
    """(T, 5): P_xy, P_xz, P_yz, (P_xx − P_yy)/2, (P_yy − P_zz)/2 of (T, 3, 3) tensors."""
    p = np.asarray(pressure_tensor, np.float64)
    return np.stack(
        [
            p[:, 0, 1],
            p[:, 0, 2],
            p[:, 1, 2],
            0.5 * (p[:, 0, 0] - p[:, 1, 1]),
            0.5 * (p[:, 1, 1] - p[:, 2, 2]),
        ],
        axis=1,
    )


def green_kubo_viscosity(
    pressure_tensor, volume: float, kT: float, dt: float, max_time: float, n_blocks: int = 10
):
    """η from a time series of pressure tensors at rest, with its standard error.

    The series is cut into `n_blocks` contiguous blocks, each much longer than
    `max_time`; in each block the autocorrelation (about the mean of the whole
    series) is integrated by the trapezoidal rule from 0 to `max_time`, where it must
    have decayed; the blocks' integrals give the mean and its standard error.

    Args:
        pressure_tensor: (T, 3, 3) pressure tensors P = −σ at equal intervals dt.
        volume: V.
        kT: k_BT (the measured temperature of the run).
        dt: time between samples.
        max_time: upper limit of the integral (time units).
        n_blocks: number of blocks (≥ 2).
    Returns:
        (η, standard error), floats.
    """
    components = traceless_components(pressure_tensor)
    components = components - components.mean(axis=0)
    block = components.shape[0] // n_blocks
    lags = int(round(max_time / dt))
    if n_blocks < 2 or block < 10 * lags:
        raise ValueError(
            f"green_kubo_viscosity: {components.shape[0]} samples in {n_blocks} blocks are "
            f"too short for max_time = {max_time} ({lags} samples; blocks need ≥ 10×)"
        )
    integrals = []
    for k in range(n_blocks):
        series = components[k * block : (k + 1) * block]
        correlation = np.asarray(time_autocorrelation(series))[: lags + 1].mean(axis=1)
        area = dt * (correlation.sum() - 0.5 * (correlation[0] + correlation[-1]))
        integrals.append(volume / kT * area)
    integrals = np.asarray(integrals)
    return float(integrals.mean()), float(integrals.std(ddof=1) / np.sqrt(n_blocks))
