"""AR(1) series, whose standard error of the mean is known exactly: the test case of
the blocking analysis."""

import numpy as np
from scipy.signal import lfilter


def ar1(phi: float, samples: int, seed: int, mean: float = 0.0, scale: float = 1.0):
    """mean + scale x_t, x_t = φ x_{t−1} + ε_t, ε ~ N(0, 1), x_0 drawn from the
    stationary distribution."""
    noise = np.random.default_rng(seed).standard_normal(samples)
    noise[0] /= np.sqrt(1 - phi**2)
    return mean + scale * lfilter([1.0], [1.0, -phi], noise)


def ar1_block_error(phi: float, samples: int, block: int) -> float:
    """The exact standard error of blocking at block length B for an AR(1) series of
    unit noise: the variance of a block mean is σ²/B [g − 2φ(1 − φ^B)/(B(1 − φ)²)]
    with σ² = 1/(1 − φ²) and the statistical inefficiency g = (1 + φ)/(1 − φ)
    (e.g. Priestley, Spectral Analysis and Time Series (1981), §5.3; Flyvbjerg &
    Petersen 1989 eq. 27 in this form), over T/B blocks.  B = T gives the exact
    standard error of the mean."""
    variance = 1 / (1 - phi**2)
    g = (1 + phi) / (1 - phi)
    block_variance = variance / block * (g - 2 * phi * (1 - phi**block) / (block * (1 - phi) ** 2))
    return float(np.sqrt(block_variance / (samples // block)))
