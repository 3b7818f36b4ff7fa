"""`jaxdpd plot RUN`: figures of a run file, each only where the file holds its data.

    thermo       temperature and pressure against time: the trace, its running mean,
                 the mean ± block standard error (20 blocks), and beside each the
                 blocking analysis (standard error against block length, Flyvbjerg &
                 Petersen 1989) with its plateau (statistics.blocking_plateau)
    stress       the pressure tensor's six components against time, with running means
    rdf          g(r) averaged over the production
    msd          the chain MSDs g1, g2, g3 of each species against lag time (log-log)
    correlations the other on-device time correlations (end-to-end, positional)
    conformation the per-step conformation series of each species, with running means
                 and the ideal-chain values (jaxdpd.analysis.run_summary)

The file is read by jaxdpd.io (nothing is built or compiled); matplotlib (the `plot`
extra) draws without pyplot, so no display or global backend is touched.
"""

from pathlib import Path

import numpy as np

from jaxdpd.analysis.run_summary import ideal_chain_references
from jaxdpd.analysis.statistics import (
    DECIDING_BLOCKS,
    block_average,
    blocking_analysis,
    blocking_plateau,
    relative_error_of_error,
)
from jaxdpd.analysis.summary_table import row_unit
from jaxdpd.io.reader import Correlation, load

FORMATS = ("png", "pdf")
N_BLOCKS = 20
MSD_NAMES = ("g1", "g2", "g3")
# Stored times are step × Δt with the step counter of the whole run (equilibration
# included; docs/file_formats.md, "Steps and times").
TIME_LABEL = "t [τ] from the run's start (equilibration included)"
TENSOR_LABELS = ((0, 0, "xx"), (1, 1, "yy"), (2, 2, "zz"), (0, 1, "xy"), (0, 2, "xz"), (1, 2, "yz"))


def _figure(rows: int, columns: int, width: float = 10.0, height: float = 3.0):
    from matplotlib.figure import Figure

    figure = Figure(figsize=(width, height * rows), layout="constrained")
    return figure, figure.subplots(rows, columns, squeeze=False)


def running_mean(values: np.ndarray) -> np.ndarray:
    """Mean of the first k samples, k = 1 … T, along the first axis."""
    counts = np.arange(1, len(values) + 1).reshape((-1,) + (1,) * (values.ndim - 1))
    return np.cumsum(values, axis=0) / counts


def _label(name: str) -> str:
    unit = row_unit(name)
    return f"{name} [{unit}]" if unit else name


def _trace(axes, time, values, name: str, reference=None) -> None:
    """A series against time with its running mean, mean ± block error and `reference`."""
    axes.plot(time, values, lw=0.5, alpha=0.5, label="per step")
    axes.plot(time, running_mean(values), lw=1.5, label="running mean")
    if len(values) >= 2 * N_BLOCKS:
        mean, error = (float(x) for x in block_average(values.astype(np.float64), N_BLOCKS))
        axes.axhspan(mean - error, mean + error, color="k", alpha=0.2, label="mean ± s.e.")
        axes.set_title(f"{name}: {mean:.5g} ± {error:.2g}", fontsize="medium")
    if reference is not None:
        axes.axhline(reference, color="C3", ls="--", label="ideal chain")
    axes.set_xlabel(TIME_LABEL)
    axes.set_ylabel(_label(name))
    axes.legend(fontsize="small")


def _blocking(axes, values, name: str) -> None:
    """The blocking analysis of a series and its plateau (or a plain 'no plateau')."""
    lengths, errors = blocking_analysis(values.astype(np.float64))
    errors = np.asarray(errors)
    spread = errors * relative_error_of_error(len(values) // lengths)
    axes.set_xscale("log", base=2)
    deciding = len(values) // lengths >= DECIDING_BLOCKS
    styles = (
        (deciding, "C0", "s.e. ± its uncertainty"),
        (~deciding, "none", f"< {DECIDING_BLOCKS} blocks: not deciding"),
    )
    for chosen, face, label in styles:
        if chosen.any():
            axes.errorbar(
                lengths[chosen], errors[chosen], spread[chosen], fmt="o", mfc=face, label=label
            )
    axes.legend(fontsize="small")
    plateau, error = blocking_plateau(values.astype(np.float64))
    if plateau is None:
        axes.set_title("no plateau: the error is a lower bound", fontsize="medium")
    else:
        axes.axvline(plateau, color="C2", ls="--")
        axes.set_title(f"plateau from {plateau} steps: s.e. {error:.2g}", fontsize="medium")
    axes.set_xlabel("block length [steps]")
    axes.set_ylabel(f"s.e. of {name}")


def thermo_figure(observables: dict):
    names = [name for name in ("temperature", "pressure") if name in observables]
    if not names:
        return None
    figure, axes = _figure(len(names), 2)
    for row, name in zip(axes, names, strict=True):
        series = observables[name]
        _trace(row[0], series.time, np.asarray(series.value), name)
        if len(series.value) >= 16:
            _blocking(row[1], np.asarray(series.value), name)
        else:
            row[1].set_visible(False)
    return figure


def stress_figure(observables: dict):
    if "pressure_tensor" not in observables:
        return None
    series = observables["pressure_tensor"]
    figure, axes = _figure(2, 1)
    for a, b, label in TENSOR_LABELS:
        values = np.asarray(series.value)[:, a, b]
        kind = axes[0, 0] if a == b else axes[1, 0]
        (line,) = kind.plot(series.time, values, lw=0.4, alpha=0.4)
        kind.plot(series.time, running_mean(values), color=line.get_color(), label=f"P_{label}")
    for axis, title in zip(axes[:, 0], ("normal", "off-diagonal"), strict=True):
        axis.set_title(f"pressure tensor, {title} components (thin: per step; thick: running mean)")
        axis.set_xlabel(TIME_LABEL)
        axis.set_ylabel(f"P [{row_unit('pressure')}]")
        axis.legend(fontsize="small", ncol=3)
    return figure


def rdf_figure(averages: dict):
    rdf = averages.get("rdf")
    if rdf is None or not rdf.samples:
        return None
    figure, axes = _figure(1, 1, width=6.0, height=4.0)
    axes[0, 0].plot(rdf.r, rdf.g)
    axes[0, 0].axhline(1.0, color="k", lw=0.5)
    axes[0, 0].set(xlabel="r [r_c]", ylabel="g(r)", title=f"g(r), {rdf.samples} frames")
    return figure


def correlation_figure(averages: dict, msd: bool):
    """The chain MSDs (msd=True) or the other correlations, log-log against lag."""
    chosen = {
        name: item
        for name, item in averages.items()
        if isinstance(item, Correlation) and (name.rsplit("/", 1)[-1] in MSD_NAMES) == msd
    }
    if not chosen:
        return None
    figure, axes = _figure(1, 1, width=6.0, height=4.5)
    for name, item in chosen.items():
        keep = np.isfinite(item.value) & (item.lag_time > 0) & (item.value > 0)
        axes[0, 0].loglog(item.lag_time[keep], item.value[keep], ".-", label=name)
    title = "MSDs: g1 beads, g2 about the centre, g3 centre"
    axes[0, 0].set(
        xlabel="lag time [τ]",
        ylabel="[r_c^2]" if msd else "correlation",
        title=title if msd else "time correlations (positive values)",
    )
    axes[0, 0].title.set_fontsize("medium")
    axes[0, 0].legend(fontsize="small")
    return figure


def conformation_figure(scene, observables: dict):
    species = {polymer.species for polymer in scene.polymers}
    names = [
        name
        for name, series in observables.items()
        if name.split("/", 1)[0] in species and np.ndim(series.value) == 1
    ]
    if not names:
        return None
    references = ideal_chain_references(scene, _temperature(observables))
    figure, axes = _figure(len(names), 1)
    for axis, name in zip(axes[:, 0], names, strict=True):
        series = observables[name]
        _trace(axis, series.time, np.asarray(series.value), name, references.get(name))
    return figure


def _temperature(observables: dict) -> dict:
    """The summary row of the mean temperature (the ideal-chain references' k_BT when
    the solvent sets none), or nothing."""
    if "temperature" not in observables:
        return {}
    return {"temperature": (float(np.mean(observables["temperature"].value)), 0.0)}


def plot_run(path, directory=None, file_format: str = "png") -> list[Path]:
    """Write the figures of the run in `path`; the paths written.

    Args:
        path: a jaxdpd H5MD file.
        directory: where to write (created if needed); default: beside the file.
        file_format: "png" or "pdf".
    Returns:
        Paths of the figures written, named `<file stem>_<figure>.<format>`.
    """
    if file_format not in FORMATS:
        raise ValueError(f"--format {file_format!r}: choose one of {', '.join(FORMATS)}")
    path = Path(path)
    record = load(path)
    directory = Path(directory) if directory is not None else path.parent
    directory.mkdir(parents=True, exist_ok=True)
    figures = {
        "thermo": thermo_figure(record.observables),
        "stress": stress_figure(record.observables),
        "rdf": rdf_figure(record.averages),
        "msd": correlation_figure(record.averages, msd=True),
        "correlations": correlation_figure(record.averages, msd=False),
        "conformation": conformation_figure(record.scene, record.observables),
    }
    written = []
    for name, figure in figures.items():
        if figure is None:
            continue
        target = directory / f"{path.stem}_{name}.{file_format}"
        figure.savefig(target, dpi=120)
        written.append(target)
    return written
