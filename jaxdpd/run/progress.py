"""Progress of a run: a tqdm bar on a terminal, plain lines in a log.

The bar starts at the end of the first chunk, so that its rate and ETA leave out the
first compilation (a later one, such as production's after equilibration resized
the buffers, is one slow chunk that tqdm's smoothing soon forgets).  It shows the
chunk's mean temperature and pressure where the scene samples them.  On a stream
that is not a terminal (output redirected to a file) nothing is redrawn: one line
at each tenth of the run, so a log holds no carriage returns.
"""

import time

from tqdm import tqdm

# Per-step series shown beside the bar (their chunk means), by the label shown.
LIVE_SERIES = {"T": "temperature", "P": "pressure"}


def live_values(series: dict) -> dict:
    """label -> chunk mean of each LIVE_SERIES the chunk holds."""
    return {
        label: f"{float(series[name].mean()):.4g}"
        for label, name in LIVE_SERIES.items()
        if name in series
    }


class Progress:
    """Progress over `total` steps on `stream` (nothing when not `enabled`)."""

    def __init__(self, total: int, stream, enabled: bool):
        self.total, self.stream, self.enabled = total, stream, enabled
        self.terminal = enabled and hasattr(stream, "isatty") and stream.isatty()
        self.bar = None
        self.next_line = 1  # the next tenth of the run to log
        self.start = time.perf_counter()

    def update(self, done: int, series: dict) -> None:
        """`done` of the total steps are finished; `series` is the latest chunk's."""
        if not self.enabled:
            return
        values = live_values(series)
        if not self.terminal:
            self._log(done, values)
        elif self.bar is None:
            self.bar = tqdm(
                total=self.total, initial=done, file=self.stream, unit="step", dynamic_ncols=True
            )
            self.bar.set_postfix(values, refresh=True)
        else:
            self.bar.set_postfix(values, refresh=False)
            self.bar.update(done - self.bar.n)

    def _log(self, done: int, values: dict) -> None:
        if done * 10 < self.next_line * self.total:
            return
        self.next_line = done * 10 // max(1, self.total) + 1
        shown = "".join(f", {label} = {value}" for label, value in values.items())
        elapsed = time.perf_counter() - self.start
        self.stream.write(
            f"[jaxdpd] {done}/{self.total} steps{shown} ({elapsed:.0f} s, compilation included)\n"
        )
        self.stream.flush()

    def finish(self) -> None:
        if self.bar is not None:
            self.bar.close()
            self.bar = None
