"""Material functions of steady planar elongational flow from the stress series.

With the axes of thesis eq. 5.12 (z stretches, x compresses, y is neutral) and the
thesis's sign convention π = p δ + τ (eq. 3.24; π is the pressure tensor P = −σ of
the "pressure_tensor" series), eqs. 3.25–3.26 define

    η̄1 = −(τ_zz − τ_xx)/ε̇ = (P_xx − P_zz)/ε̇,
    η̄2 = −(τ_yy − τ_xx)/ε̇ = (P_xx − P_yy)/ε̇.

A Newtonian fluid, τ = −η (∇u + ∇uᵀ) = −2η diag(−ε̇, 0, ε̇), has η̄1 = 4η and η̄2 = 2η:
the Trouton ratio η̄1/η = 4 of planar elongation (thesis §4.3.3).  A real fluid at
small ε̇ is a second-order fluid, for which η̄1 = 4η + O(ε̇²) but
η̄2 = 2η − 4ε̇(Ψ1/2 + Ψ2) + O(ε̇²) with Ψ1, Ψ2 its zero-rate normal-stress
coefficients (derived in tests/test_planar_elongation_slow.py): the standard DPD
fluid's η̄2/2 lies 5 % above η at ε̇ = 0.2 (benchmarks/elongation_second_order.py).

The polymer contributions are the same differences of the springs' part of the
stress, "pressure_tensor_part/bond": the Kramers expression (thesis eq. 3.48), whose
isotropic n k_BT cancels in the differences.
"""

import numpy as np

from jaxdpd.analysis.statistics import block_average

# Series of the total stress and of its springs' part (jaxdpd.observables.thermo).
TOTAL = "pressure_tensor"
POLYMER = "pressure_tensor_part/bond"


def elongational_viscosities(pressure_tensor, elongation_rate):
    """η̄1 and η̄2 of each stress sample.

    Args:
        pressure_tensor: (..., 3, 3) pressure tensors P = −σ (or a part of one).
        elongation_rate: ε̇ ≠ 0, a scalar or an array broadcasting against (...).
    Returns:
        (η̄1, η̄2), each of shape (...).
    """
    tensor = np.asarray(pressure_tensor)
    rate = np.asarray(elongation_rate)
    if np.any(rate == 0):
        raise ValueError("elongation_rate: η̄1 and η̄2 are defined for ε̇ ≠ 0")
    return (
        (tensor[..., 0, 0] - tensor[..., 2, 2]) / rate,
        (tensor[..., 0, 0] - tensor[..., 1, 1]) / rate,
    )


def elongational_material_functions(series: dict, elongation_rate, n_blocks: int = 20, axis=0):
    """Means and standard errors of η̄1, η̄2 and their polymer parts.

    Args:
        series: a run's time series (jaxdpd.observables.thermo.reduce_samples), with
            "pressure_tensor" and, in a polymer solution, "pressure_tensor_part/bond";
            time on `axis` (1 for an ensemble's (B, T, 3, 3) series).
        elongation_rate: ε̇, scalar or one per replica (B,) for an ensemble.
        n_blocks: blocks of the block average (jaxdpd.analysis.statistics.block_average).
    Returns:
        name → (mean, standard error) for "eta1", "eta2" and, when the springs' part
        was recorded, "eta1_polymer", "eta2_polymer" (arrays of shape (B,) for an
        ensemble).
    """
    if TOTAL not in series:
        raise ValueError("series: no 'pressure_tensor'; add 'pressure' to output.observables")
    rate = np.asarray(elongation_rate, np.float64)
    # One rate per replica: align it with the replica axis, before the time axis.
    rate = rate.reshape(rate.shape + (1,) * axis) if rate.ndim else rate
    results = {}
    parts = [("", TOTAL)] + ([("_polymer", POLYMER)] if POLYMER in series else [])
    for suffix, name in parts:
        eta1, eta2 = elongational_viscosities(np.asarray(series[name], np.float64), rate)
        for label, values in (("eta1", eta1), ("eta2", eta2)):
            mean, error = block_average(values, n_blocks=n_blocks, axis=axis)
            results[label + suffix] = (np.asarray(mean), np.asarray(error))
    return results
