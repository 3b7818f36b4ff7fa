"""Shear viscosity from equilibrium stress fluctuations (Green–Kubo).

    η = (V / k_BT) ∫₀^∞ ⟨P_αβ(0) P_αβ(t)⟩ dt,   α ≠ β,

averaged over the three off-diagonal components of the pressure tensor of an
isotropic fluid at rest (Allen & Tildesley, *Computer Simulation of Liquids*, 2nd ed.
(2017), §2.7 and §8.5).  The per-step samples are the step's tensor held over the
step, so the integral is the trapezoidal rule on the samples; a part that is
uncorrelated from step to step (the Lowe–Andersen impulse stress) then contributes
half its lag-0 term, which is what the long-time (Einstein–Helfand) form
Var(∫ P_xy dt) = 2 T ∫₀^∞ C dt gives for a piecewise-constant signal.
"""

import numpy as np

from jaxdpd.analysis.dynamics import time_autocorrelation
from jaxdpd.analysis.statistics import block_average

OFF_DIAGONAL = ((0, 1), (0, 2), (1, 2))


def running_integral(pressure_tensors, volume: float, kT: float, dt: float, max_lag: int):
    """(V/k_BT) ∫₀^{k Δt} C(t) dt for k = 0 .. max_lag − 1, C the off-diagonal mean.

    Args:
        pressure_tensors: (T, 3, 3) one tensor per sample, Δt apart (T > max_lag).
        volume: V.
        kT: k_BT.
        dt: time between samples.
        max_lag: number of lags integrated.
    Returns:
        (max_lag,) NumPy running integral (units of viscosity).
    """
    shear = np.stack([np.asarray(pressure_tensors)[:, a, b] for a, b in OFF_DIAGONAL], axis=1)
    shear = shear - shear.mean(axis=0)
    correlation = np.asarray(time_autocorrelation(shear))[:max_lag].mean(axis=1)
    return volume / kT * dt * (np.cumsum(correlation) - 0.5 * correlation[0] - 0.5 * correlation)


def shear_viscosity(
    pressure_tensors, volume: float, kT: float, dt: float, max_lag: int, n_blocks: int = 10
):
    """Green–Kubo η integrated to t_max = (max_lag − 1) Δt, with an error bar.

    The integral is evaluated on `n_blocks` consecutive blocks of the series (each
    much longer than t_max); the estimate is their mean and the error their standard
    error (jaxdpd.analysis.statistics.block_average).

    Args:
        pressure_tensors: (T, 3, 3) per-step pressure tensors of a fluid at rest.
        volume, kT, dt, max_lag: as in `running_integral`.
        n_blocks: number of blocks (≥ 2).
    Returns:
        (η, standard error) as Python floats.
    """
    tensors = np.asarray(pressure_tensors, np.float64)
    length = len(tensors) // n_blocks
    if length <= max_lag:
        raise ValueError(
            f"blocks of {length} samples must be longer than max_lag = {max_lag}; "
            "run longer or use fewer blocks"
        )
    blocks = [tensors[k * length : (k + 1) * length] for k in range(n_blocks)]
    integrals = np.array([running_integral(b, volume, kT, dt, max_lag)[-1] for b in blocks])
    mean, error = block_average(integrals, n_blocks=n_blocks)
    return float(mean), float(error)
