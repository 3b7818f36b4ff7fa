"""The rows of a run's summary: mean ± standard error of every scalar series, some
components of the pressure tensor, D_CM from the chain correlators, and the derived
estimates of each observable component (material functions, drag coefficients).

One function serves the runner, which has running block sums at the end of a run,
and `jaxdpd summary`, which reads the series back from the file
(`RunningBlockAverages.add` of the whole series gives the same blocks).
"""

import numpy as np

from jaxdpd.analysis.running_averages import RunningBlockAverages
from jaxdpd.geometry.chain_topology import chain_blocks
from jaxdpd.observables import summary_rows
from jaxdpd.observables.chain_correlators import center_of_mass_diffusion
from jaxdpd.observables.chain_series import ideal_references

# Components of the pressure tensor reported in the summary table: (row, column, name).
TENSOR_COMPONENTS = (
    (0, 1, "P_xy"),
    (1, 0, "P_yx"),
    (0, 0, "P_xx"),
    (1, 1, "P_yy"),
    (2, 2, "P_zz"),
)


def series_rows(averages: RunningBlockAverages) -> dict:
    """name -> (mean, standard error): every scalar series, and the pressure tensor's
    TENSOR_COMPONENTS."""
    rows = {}
    for name in averages.names:
        mean, error = averages.result(name)
        if mean.ndim == 0:
            rows[name] = (float(mean), float(error))
        elif name == "pressure_tensor":
            for a, b, label in TENSOR_COMPONENTS:
                rows[label] = (float(mean[a, b]), float(error[a, b]))
    return rows


def row_series(series: dict) -> dict:
    """name -> (T,) per-step series of each row of `series_rows` (for the blocking
    check of `jaxdpd summary`), from the stored per-step series."""
    rows = {}
    for name, values in series.items():
        values = np.asarray(values)
        if values.ndim == 1:
            rows[name] = values
        elif name == "pressure_tensor":
            rows.update({label: values[:, a, b] for a, b, label in TENSOR_COMPONENTS})
    return rows


def table_rows(scene, averages: RunningBlockAverages, correlations: dict) -> dict:
    """Every row of the summary: name -> (mean, standard error).

    Args:
        scene: the run's scene.
        averages: block sums of the production's series.
        correlations: name -> (lag times, per-element values) of the chain
            correlators ("<species>/g3", ...; empty without them).
    """
    # Under shear g3 holds the flow's dispersion along x: no D_CM from its slope.
    diffusion = center_of_mass_diffusion(correlations) if scene.flow is None else {}
    return (
        series_rows(averages)
        | diffusion
        | summary_rows(scene, averages.block_means(), averages.n_blocks)
    )


def ideal_chain_references(scene, rows: dict) -> dict:
    """name -> the exact value for ideal chains (jaxdpd.observables.chain_series), at
    the solvent's set k_BT, or for a Hoogerbrugge–Koelman fluid, which sets none (its
    solvent.kT is only the starting value), at the measured mean kinetic temperature
    (no references when it was not measured)."""
    if scene.solvent_component.sets_temperature:
        kT = scene.solvent.kT
    elif "temperature" in rows:
        kT = rows["temperature"][0]
    else:
        return {}
    return ideal_references(chain_blocks(scene), kT)
