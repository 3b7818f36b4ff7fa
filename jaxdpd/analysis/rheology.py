"""Material functions of steady simple shear from a run's stress series.

With the pressure tensor P = −σ of jaxdpd.observables.thermo (Irving–Kirkwood, thesis
eqs. 3.46–3.49) and u_x = γ̇ (y − L_y/2):

    η  = −⟨P_xy⟩/γ̇,
    Ψ1 = N1/γ̇²,  N1 = σ_xx − σ_yy = ⟨P_yy⟩ − ⟨P_xx⟩,   (normal_stress_differences)
    Ψ2 = N2/γ̇²,  N2 = σ_yy − σ_zz = ⟨P_zz⟩ − ⟨P_yy⟩

(Bird, Armstrong & Hassager, *Dynamics of Polymeric Liquids* vol. 1, 2nd ed. (1987),
ch. 3; thesis eqs. 4.12–4.13).  The polymer contributions η_p, Ψ1,p, Ψ2,p are the
same functions of the Kramers spring part "pressure_tensor_part/bond" (thesis eq.
3.48: its isotropic n k_BT drops out of every material function), and every other
part ("kinetic", "conservative", "dissipative", "random") gives its share of η.

Series are per-step samples, the time axis next to the tensor axes, with any
leading axes (a replica axis of jaxdpd.run.ensemble); shear_rate is a scalar or one
value per replica.  Errors are block averages over time (jaxdpd.analysis.statistics); a
replica at γ̇ = 0 gets NaN.  The run summary's rows come from the observables
(jaxdpd.observables.summary_rows).
"""

import jax.numpy as jnp

from jaxdpd.analysis.statistics import block_average
from jaxdpd.precision import as_array

MATERIAL_FUNCTIONS = ("viscosity", "psi1", "psi2")
PART_PREFIX = "pressure_tensor_part/"


def material_function_series(pressure_tensor, shear_rate) -> dict:
    """Per-sample η, Ψ1, Ψ2 from a pressure-tensor series.

    Args:
        pressure_tensor: (..., T, 3, 3) P (or one of its parts).
        shear_rate: γ̇, scalar or (...) (one per replica).
    Returns:
        {"viscosity", "psi1", "psi2"} → (..., T) series (NaN where γ̇ = 0).
    """
    pressure = as_array(pressure_tensor)
    if pressure.ndim < 3 or pressure.shape[-2:] != (3, 3):
        raise ValueError(f"pressure_tensor must be (..., T, 3, 3), got {pressure.shape}")
    rate = jnp.asarray(shear_rate, pressure.dtype)[..., None]
    rate = jnp.where(rate == 0, jnp.nan, rate)
    shear = 0.5 * (pressure[..., 0, 1] + pressure[..., 1, 0])
    first, second = normal_stress_difference_series(pressure)
    return {"viscosity": -shear / rate, "psi1": first / rate**2, "psi2": second / rate**2}


def normal_stress_difference_series(pressure_tensor):
    """Per-sample N1 = σ_xx − σ_yy = P_yy − P_xx and N2 = σ_yy − σ_zz = P_zz − P_yy
    (k_BT/r_c³) of a (..., 3, 3) pressure-tensor series (P = −σ)."""
    pressure = as_array(pressure_tensor)
    return (
        pressure[..., 1, 1] - pressure[..., 0, 0],
        pressure[..., 2, 2] - pressure[..., 1, 1],
    )


def normal_stress_differences(pressure_tensor, n_blocks: int = 20) -> dict:
    """N1 and N2 of a (T, 3, 3) pressure-tensor series with block-average standard
    errors: {"N1", "N2"} → (mean, standard error)."""
    first, second = normal_stress_difference_series(pressure_tensor)
    return {
        "N1": block_average(first, n_blocks=n_blocks),
        "N2": block_average(second, n_blocks=n_blocks),
    }


def material_functions(pressure_tensor, shear_rate, n_blocks: int = 20) -> dict:
    """η, Ψ1, Ψ2 with block-average standard errors.

    Args:
        pressure_tensor: (..., T, 3, 3) series.
        shear_rate: γ̇, scalar or (...).
        n_blocks: blocks of the time series.
    Returns:
        name → (mean, standard error), arrays of shape (...).
    """
    series = material_function_series(pressure_tensor, shear_rate)
    return {
        name: block_average(values, n_blocks=n_blocks, axis=-1) for name, values in series.items()
    }


def shear_rheology(series: dict, shear_rate, n_blocks: int = 20) -> dict:
    """Material functions of the whole fluid, the polymer and each stress part.

    Args:
        series: a run's series ("pressure_tensor" and "pressure_tensor_part/<part>",
            shapes (..., T, 3, 3); jaxdpd.observables.thermo.reduce_samples).
        shear_rate: γ̇, scalar or (...).
        n_blocks: blocks of the time series.
    Returns:
        name → (mean, standard error): "viscosity", "psi1", "psi2" (total);
        "polymer/viscosity", "polymer/psi1", "polymer/psi2" (Kramers spring part,
        when the run has one); "viscosity_part/<part>" for every other part.
    """
    if "pressure_tensor" not in series:
        raise ValueError("series: no 'pressure_tensor'; the scene must observe 'pressure'")
    results = material_functions(series["pressure_tensor"], shear_rate, n_blocks)
    for name, values in series.items():
        if not name.startswith(PART_PREFIX):
            continue
        part = name[len(PART_PREFIX) :]
        functions = material_functions(values, shear_rate, n_blocks)
        if part == "bond":
            results.update({f"polymer/{key}": value for key, value in functions.items()})
        else:
            results[f"viscosity_part/{part}"] = functions["viscosity"]
    return results


def conformation_components(conformation, n_blocks: int = 20) -> dict:
    """The components of a conformation tensor series that shear makes nonzero.

    Args:
        conformation: (..., T, 3, 3) ⟨QQ⟩ series ("<species>/bond_conformation").
    Returns:
        {"xy": ⟨Q_x Q_y⟩, "xx-yy": ⟨Q_x²⟩ − ⟨Q_y²⟩, "yy-zz": ⟨Q_y²⟩ − ⟨Q_z²⟩} →
        (mean, standard error); all vanish at rest (isotropy).
    """
    tensor = as_array(conformation)
    components = {
        "xy": 0.5 * (tensor[..., 0, 1] + tensor[..., 1, 0]),
        "xx-yy": tensor[..., 0, 0] - tensor[..., 1, 1],
        "yy-zz": tensor[..., 1, 1] - tensor[..., 2, 2],
    }
    return {
        key: block_average(values, n_blocks=n_blocks, axis=-1) for key, values in components.items()
    }
