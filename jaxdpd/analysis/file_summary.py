"""`jaxdpd summary RUN`: the summary table of a run file, with units, a glossary and a
blocking check of each error bar.

The rows are those the run printed at its end (jaxdpd.analysis.run_summary), computed
again from the stored series and /averages (read by jaxdpd.io; nothing is built or
compiled).  The table's error bars come from 20 block averages; such an error is
trusted only when the blocks are past the plateau of the Flyvbjerg–Petersen blocking
analysis (jaxdpd.analysis.statistics.blocking_plateau).  Each row that has a per-step
series says whether they are; rows derived from several series (material functions,
drag, D_CM) get no verdict of their own.
"""

from dataclasses import dataclass

import numpy as np

from jaxdpd.analysis.run_summary import ideal_chain_references, row_series, table_rows
from jaxdpd.analysis.running_averages import RunningBlockAverages
from jaxdpd.analysis.statistics import (
    DECIDING_BLOCKS,
    blocking_plateau,
    relative_error_of_error,
)
from jaxdpd.analysis.summary_table import format_table, glossary, rdf_rows
from jaxdpd.analysis.temperature_check import temperature_warning
from jaxdpd.io.reader import Correlation, load


@dataclass(frozen=True)
class Verdict:
    """The blocking check of one row's error bar.

    Attributes:
        plateau: block length (samples) at which the blocking analysis plateaus, or
            None when it does not within the series.
        plateau_error: the standard error there (when None, the largest of the levels
            that may decide, a lower bound).
        block_length: the length of the table's blocks.
        samples: the series' length (for the uncertainty of the plateau's error).
    """

    plateau: int | None
    plateau_error: float
    block_length: int
    samples: int

    @property
    def trusted(self) -> bool:
        return self.plateau is not None and self.block_length >= self.plateau

    def note(self) -> str:
        if self.plateau is None:
            return f"NO PLATEAU (s.e. ≥ {self.plateau_error:.2g})"
        spread = f"{relative_error_of_error(self.samples // self.plateau):.0%}"
        if self.trusted:
            return f"ok (plateau from {self.plateau}, s.e. ± {spread})"
        return (
            f"blocks too short: plateau at {self.plateau}, s.e. {self.plateau_error:.2g} ± {spread}"
        )


def verdict(series, block_length: int) -> Verdict:
    """The blocking check of a (T,) series whose error came from blocks of
    `block_length` samples."""
    plateau, error = blocking_plateau(np.asarray(series, np.float64))
    return Verdict(plateau, error, block_length, len(series))


def verdicts(series: dict, block_length: int) -> dict:
    """row name -> Verdict for each summary row with a per-step series of at least
    16 samples (the blocking analysis needs two levels)."""
    return {
        name: verdict(values, block_length)
        for name, values in row_series(series).items()
        if len(values) >= 16
    }


@dataclass
class FileSummary:
    """The summary of a run file, as `read_summary` computes it.

    Attributes:
        path, scene: the file and its scene.
        checkpoint: the checkpoint header, or None.
        samples: production steps stored (of scene.run.steps).
        steps: (first, last) step number stored, on the run's step counter, which
            counts the equilibration steps too; None without series.
        averages: the block sums of the stored series (n_blocks, block_length).
        rows: name -> (mean, standard error), as the run printed them.
        references, warnings, extra: as jaxdpd.analysis.summary_table.format_table.
        checks: row name -> Verdict of each row with a per-step series.
    """

    path: object
    scene: object
    checkpoint: object
    samples: int
    steps: tuple[int, int] | None
    averages: RunningBlockAverages
    rows: dict
    references: dict
    warnings: dict
    extra: dict
    checks: dict

    def text(self) -> str:
        """A header, the table with units and verdicts, a plain statement of the rows
        without a plateau, a glossary."""
        scene, averages = self.scene, self.averages
        stored = "" if self.checkpoint is None else f"; checkpoint: {self.checkpoint.reason}"
        notes = {name: check.note() for name, check in self.checks.items()}
        counted = (
            ""
            if self.steps is None
            else f" (steps {self.steps[0]}–{self.steps[1]}: step numbers count the "
            f"{scene.run.equilibration} equilibration steps too)"
        )
        lines = [
            f"{self.path}: {scene.solvent.method} solvent, N = {scene.n_particles}, "
            f"{self.samples} production steps stored of {scene.run.steps}{counted}{stored}",
            f"errors: {averages.n_blocks} block averages of {averages.block_length} steps; "
            "verdict: blocking analysis (Flyvbjerg & Petersen 1989; plateau criterion of "
            f"Lee et al., Phys. Rev. E 83, 066706 (2011), decided by levels of ≥ "
            f"{DECIDING_BLOCKS} blocks; ± is the uncertainty of the plateau's s.e.)",
            "",
            format_table(self.rows, self.references, self.warnings, self.extra, notes),
            "",
        ]
        failing = [name for name, check in self.checks.items() if check.plateau is None]
        short = [name for name, check in self.checks.items() if check.plateau and not check.trusted]
        if failing:
            lines.append(
                f"No blocking plateau was reached for {', '.join(failing)}: the run is too "
                "short for the correlation time, and those error bars are lower bounds."
            )
        if short:
            lines.append(
                f"The table's blocks are shorter than the plateau for {', '.join(short)}: "
                "trust the plateau's standard error given beside them."
            )
        if self.checks and not failing and not short:
            lines.append("Every error bar with a per-step series is past its blocking plateau.")
        lines += ["", glossary([*self.rows, *self.extra])]
        return "\n".join(lines)


def read_summary(path) -> FileSummary:
    """The summary of the run in `path`, from its stored series and /averages."""
    record = load(path)
    scene = record.scene
    series = {name: np.asarray(stored.value) for name, stored in record.observables.items()}
    samples = min((len(values) for values in series.values()), default=0)
    counters = [np.asarray(stored.step) for stored in record.observables.values()]
    steps = (int(counters[0][0]), int(counters[0][samples - 1])) if samples else None
    averages = RunningBlockAverages(samples)
    averages.add(0, {name: values[:samples] for name, values in series.items()})
    correlations = {
        name: (item.lag_time, item.per_element)
        for name, item in record.averages.items()
        if isinstance(item, Correlation)
    }
    rows = table_rows(scene, averages, correlations) if samples else {}
    checks = verdicts(series, averages.block_length) if averages.n_blocks > 1 else {}
    warnings = {}
    if "temperature" in rows:
        message = temperature_warning(scene, *rows["temperature"])
        warnings = {} if message is None else {"temperature": message}
    rdf = record.averages.get("rdf")
    extra = rdf_rows(rdf.r, rdf.g) if rdf is not None and rdf.samples else {}
    references = ideal_chain_references(scene, rows)
    return FileSummary(
        path,
        scene,
        record.checkpoint,
        samples,
        steps,
        averages,
        rows,
        references,
        warnings,
        extra,
        checks,
    )


def summarize(path) -> str:
    """The summary of the run in `path` as text (`FileSummary.text`)."""
    return read_summary(path).text()
