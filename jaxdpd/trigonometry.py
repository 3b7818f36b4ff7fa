"""Sine and cosine of 2πt at the price of a polynomial.

XLA's CPU sine and cosine cost about 15 times a fused polynomial of the same array
(measured: 0.82 ms against 0.05 ms for 30 000 float64 values), which made them the
largest cost of the transverse-current observable and of the MPCD rotation axes.
"""

import math

import jax
import jax.numpy as jnp
import numpy as np

# Taylor coefficients (−1)^k / (2k+1)! and (−1)^k / (2k)! up to φ¹⁵ and φ¹⁴: on
# |φ| ≤ π/4 the truncation error is below 3·10⁻¹⁴ (float64 round-off scale).
_SINE_TERMS = tuple((-1) ** k / math.factorial(2 * k + 1) for k in range(8))
_COSINE_TERMS = tuple((-1) ** k / math.factorial(2 * k) for k in range(8))


def sincos_turns(turns):
    """sin(2π t) and cos(2π t), elementwise, by quadrant reduction and Taylor series.

    Quadrant reduction to |φ| ≤ π/4, then Taylor series to φ¹⁵ (sine) and φ¹⁴
    (cosine), evaluated by Horner's rule.

    Args:
        turns: array t (any real values; float32 or float64, kept).
    Returns:
        (sin 2πt, cos 2πt), each to within a few round-off units of `turns`' dtype.
    """
    quarter_turns = 4 * (turns - jnp.round(turns))  # in [−2, 2]
    quadrant = jnp.round(quarter_turns)
    angle = (quarter_turns - quadrant) * (jnp.pi / 2)  # φ in [−π/4, π/4]
    sine, cosine = sincos_small(angle)
    # sin(φ + qπ/2), cos(φ + qπ/2) for q mod 4 = 0, 1, 2, 3.
    # lax.select_n picks by the index itself (jnp.select would find the first true
    # condition with a reduction).
    q = jnp.mod(quadrant.astype(jnp.int32), 4)
    rotated_sine = jax.lax.select_n(q, sine, cosine, -sine, -cosine)
    rotated_cosine = jax.lax.select_n(q, cosine, -sine, -cosine, sine)
    return rotated_sine, rotated_cosine


def sincos_small(angle):
    """sin φ and cos φ for |φ| ≤ π/4 (no range reduction): Taylor series to φ¹⁵ and
    φ¹⁴ by Horner's rule, truncation error below 3·10⁻¹⁴.

    Args:
        angle: array φ with |φ| ≤ π/4 (float32 or float64, kept).
    Returns:
        (sin φ, cos φ).
    """
    angle_sq = angle * angle
    sine = cosine = 0
    for s_term, c_term in zip(reversed(_SINE_TERMS), reversed(_COSINE_TERMS), strict=True):
        sine = sine * angle_sq + s_term
        cosine = cosine * angle_sq + c_term
    return sine * angle, cosine


def _trisection_coefficients(degree: int = 18):
    """Chebyshev coefficients of y(s) = cos(arccos(1 − 2s²)/3 − 2π/3) on s ∈ [0, 1/√2]
    (mapped to [−1, 1]).  y is analytic there (its nearest singularity is s = 1), so
    degree 18 gives about 1e-12 (measured against NumPy's float64 arccos and cos)."""
    s_max = 1 / math.sqrt(2)

    def exact(t):
        s = (t + 1) / 2 * s_max
        return np.cos(np.arccos(1 - 2 * s * s) / 3 - 2 * math.pi / 3)

    return tuple(float(c) for c in np.polynomial.chebyshev.chebinterpolate(exact, degree))


_TRISECTION = _trisection_coefficients()


def trisected_cosine(x):
    """cos(arccos(x)/3 − 2π/3) for x ∈ [−1, 1]: the root in [−1/2, 1/2] of 4y³ − 3y = x
    (Viète's middle root of a cubic with three real roots).

    XLA's CPU arccos and cosine are scalar library calls (≈ 45 ns per value in
    float64); this is a Chebyshev series (Clenshaw) in s = √((1 − |x|)/2) on the half
    x ≥ 0 and the odd symmetry y(−x) = −y(x), accurate to ≈ 1e-12 absolute (float64).

    Args:
        x: array in [−1, 1] (float32 or float64, kept).
    Returns:
        y, the shape of x.
    """
    s = jnp.sqrt((1 - jnp.abs(x)) / 2)
    t2 = 2 * (2 * math.sqrt(2) * s - 1)  # 2t, t = s / s_max mapped to [−1, 1]
    later = current = 0
    for coefficient in reversed(_TRISECTION[1:]):
        later, current = current, t2 * current - later + coefficient
    y = t2 / 2 * current - later + _TRISECTION[0]
    return jnp.where(x < 0, -y, y)
