"""Temperature sanity: is a run's measured k_BT the one its thermostat was set to?

In a thermostatted particle solvent the kinetic temperature (of the peculiar
velocities under flow, thesis §3.5.1) is the first indicator of the accuracy of the
integration: Groot and Warren's modified velocity Verlet at Δt = 0.04 keeps it within
1 % of the set point at rest (thesis §2.2.1, Groot & Warren, J. Chem. Phys. 107, 4423
(1997)).  It fails quietly: too large a step, or a strong flow, heats the DPD fluid
(the flow-curve notebook measures k_BT = 1.11 at γ̇ = 1 and 1.48 at γ̇ = 2 with
Δt = 0.04, λ = 0.65).  The thesis keeps its fluid at temperature by using the
Lowe–Andersen thermostat with Δt = 0.01, "no simulation shows a temperature error
greater than 0.5 %" (thesis §4.3.1), and by staying at shear rates up to about 0.3,
above which the viscosity of the simple DPD fluid drops, with either thermostat
(thesis §4.2.7).  benchmarks/stability_map.py maps the temperature of each solvent
over shear rate and Δt (N = 375): at γ̇ ≤ 0.3 both hold k_BT within 3 % for
Δt ≤ 0.06 (Groot–Warren heats by 20 % at Δt = 0.1); at γ̇ = 1 and 2 Groot–Warren
measures 1.08–1.11 and 1.41–1.43 and Lowe–Andersen (Γ = 10) 1.02–1.03 and 1.10–1.11,
whatever Δt in 0.01–0.06: the heating under strong shear is not an error of the step.

A run's mean k_BT is flagged when it departs from the set value by more than
RELATIVE_TOLERANCE of it and, where a block-average error exists, by more than
STANDARD_ERRORS of them (a departure that large is not a fluctuation).  Without an
error (runs too short for 20 blocks) the relative tolerance alone decides.
"""

import math

import numpy as np

from jaxdpd.analysis.statistics import block_average

RELATIVE_TOLERANCE = 0.03
STANDARD_ERRORS = 3.0


def is_off(mean: float, error: float, set_value: float) -> bool:
    """Whether a mean temperature departs from `set_value` by more than
    RELATIVE_TOLERANCE of it and (unless `error` is NaN) by more than
    STANDARD_ERRORS standard errors.  A non-finite mean is always off."""
    if not math.isfinite(mean):
        return True
    departure = abs(mean - set_value)
    beyond_noise = math.isnan(error) or departure > STANDARD_ERRORS * error
    return departure > RELATIVE_TOLERANCE * set_value and beyond_noise


def set_temperature(scene) -> float | None:
    """The thermostat's k_BT of a scene, or None where the scene sets none to compare
    with (Hoogerbrugge–Koelman, whose temperature follows from its collision rule, or
    a lattice-Boltzmann fluid without fluctuations)."""
    if not scene.solvent_component.sets_temperature or scene.solvent.kT <= 0:
        return None
    return scene.solvent.kT


def temperature_warning(scene, mean: float, error: float) -> str | None:
    """A warning naming the departure and the likely fix, or None when `mean` ± `error`
    (the run's block-averaged k_BT) agrees with the scene's set temperature."""
    set_value = set_temperature(scene)
    if set_value is None or not is_off(mean, error, set_value):
        return None
    spread = "" if math.isnan(error) else f" ± {error:.2g}"
    relative = (mean - set_value) / set_value
    return (
        f"temperature: measured k_BT = {mean:.4g}{spread} against the set "
        f"solvent.kT = {set_value:g} ({relative:+.1%}; the thermostat does not hold it, "
        f"so every average of this run is at another state point); "
        f"{scene.solvent_component.heating_advice}"
    )


def flag_points(temperature, set_value: float, n_blocks: int = 20) -> np.ndarray:
    """Which state points of a sweep are off temperature (for sweep summaries).

    Args:
        temperature: (R, T) k_BT series of R replicas (e.g. one per shear rate).
        set_value: the set k_BT.
        n_blocks: blocks of the error estimate (jaxdpd.analysis.statistics.block_average).
    Returns:
        (R,) bool: `is_off` of each replica's block-averaged mean.
    """
    temperature = np.asarray(temperature, np.float64)
    if temperature.ndim != 2:
        raise ValueError(f"temperature: shape {temperature.shape}; give (replicas, steps)")
    blocks = n_blocks if temperature.shape[1] >= 2 * n_blocks else None
    flags = []
    for series in temperature:
        if blocks is None:
            mean, error = float(series.mean()), math.nan
        else:
            mean, error = (float(x) for x in block_average(series, n_blocks=blocks))
        flags.append(is_off(mean, error, set_value))
    return np.asarray(flags)
