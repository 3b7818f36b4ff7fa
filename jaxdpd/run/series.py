"""Run a simulation (one replica or a batch) and gather its time series on the host."""

import numpy as np

from jaxdpd.run import driver, ensemble


def collect(simulation, state, steps: int, chunk: int, on_chunk=None):
    """Run `steps` steps and concatenate every chunk's series.

    A single state or a batch (leading replica axis, as made by
    jaxdpd.run.ensemble.replicate) runs through jaxdpd.run.driver.run.

    Args:
        simulation: from jaxdpd.engine.build.build.
        state: a SimState or a batch of them.
        steps: steps to run (≥ 0).
        chunk: steps per jitted chunk.
        on_chunk: also called with each ChunkResult (e.g. to keep positions).
    Returns:
        (final state, name → NumPy array with time on axis 0, or on axis 1 after
        the replica axis of a batch).
    """
    parts = {}

    def keep(result):
        for name, values in result.series.items():
            parts.setdefault(name, []).append(np.asarray(values))
        if on_chunk is not None:
            on_chunk(result)

    state = driver.run(simulation, state, steps, chunk, on_chunk=keep)
    axis = 1 if ensemble.is_batch(state) else 0
    return state, {name: np.concatenate(values, axis=axis) for name, values in parts.items()}
