"""Block averages of series that arrive chunk by chunk, without keeping the series.

`jaxdpd.analysis.statistics.block_average` cuts a series of T samples into n_b contiguous
blocks of b = ⌊T/n_b⌋ samples, dropping the first T − n_b b.  When T is known before
the run starts, every sample's block is known as it arrives, so a run only needs to
keep n_b block sums per series: memory does not grow with the run length.  At the
end the block means go through `block_average` itself (n_b blocks of one sample each
give back the same mean and standard error).

Sums are accumulated in float64, chunk after chunk, in arrival order; adding the
same chunks in the same order (e.g. replayed from a file after a restart) gives the
same bits.
"""

import numpy as np

from jaxdpd.analysis.statistics import block_average


class RunningBlockAverages:
    """Running block sums of named per-step series.

    Args:
        total: number of samples T each series will have.
        n_blocks: blocks n_b; a series shorter than `min_block_length` × n_b samples
            gets one block (a plain mean, with a NaN standard error).
        min_block_length: the shortest block worth an error estimate.
    """

    def __init__(self, total: int, n_blocks: int = 20, min_block_length: int = 2):
        if total < 0:
            raise ValueError(f"total = {total} samples must be ≥ 0")
        self.total = total
        self.n_blocks = n_blocks if total >= min_block_length * n_blocks else 1
        self.block_length = max(1, total // self.n_blocks)
        self.discarded = total - self.n_blocks * self.block_length if total else 0
        self.sums: dict[str, np.ndarray] = {}

    def add(self, first_index: int, series: dict) -> None:
        """Add samples first_index … first_index + n − 1 of each series.

        Args:
            first_index: index (from 0) of the chunk's first sample in the run.
            series: name -> array (n, ...) of the chunk's samples.
        """
        for name, values in series.items():
            values = np.asarray(values, np.float64)
            index = np.arange(first_index, first_index + len(values))
            kept = (index >= self.discarded) & (index < self.total)
            sums = self.sums.setdefault(name, np.zeros((self.n_blocks, *values.shape[1:])))
            np.add.at(sums, (index[kept] - self.discarded) // self.block_length, values[kept])

    def result(self, name: str):
        """(mean, standard error) of one series as NumPy arrays of its sample shape;
        the error is NaN with a single block."""
        means = self.sums[name] / self.block_length
        if self.n_blocks == 1:
            return means[0], np.full(means.shape[1:], np.nan)
        mean, error = block_average(means, n_blocks=self.n_blocks)
        return np.asarray(mean), np.asarray(error)

    def block_means(self) -> dict:
        """name -> (n_blocks, ...) block means of every series (a series of its own:
        `block_average` of it with n_blocks blocks gives `result`)."""
        return {name: sums / self.block_length for name, sums in self.sums.items()}

    @property
    def names(self) -> list[str]:
        """Names of the series seen so far."""
        return list(self.sums)
