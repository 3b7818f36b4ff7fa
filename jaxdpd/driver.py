"""The run driver: jitted `lax.scan` chunks, error checks between chunks.

After every chunk the driver reads the state's error flags:
- neighbour overflow: the buffers are reallocated from the needs the chunk recorded
  and the chunk is rerun from its saved start state (no step lost or duplicated);
- anything else (non-finite values, ...): the last good state (the chunk's start)
  is handed to `on_error` (e.g. written as a checkpoint) and `SimulationError` is
  raised with a message saying what went wrong and what to change.
"""

from collections.abc import Callable
from dataclasses import dataclass
from functools import partial

import jax
import numpy as np

from jaxdpd import errors
from jaxdpd.observables.thermo import reduce_samples

MAX_REALLOCATIONS = 8


@dataclass
class ChunkResult:
    """What one chunk produced (host-side NumPy)."""

    state: object
    first_step: int
    steps: int
    series: dict


@partial(jax.jit, static_argnums=(0, 2))
def _scan_chunk(step_fn, state, length: int):
    return jax.lax.scan(lambda carry, _: step_fn(carry), state, None, length=length)


def run_chunk(simulation, state, length: int):
    """Advance `length` steps, reallocating neighbour buffers on overflow.

    Returns:
        (new state, per-step samples as NumPy arrays, number of reallocations).
    Raises:
        SimulationError: on any error flag other than a neighbour overflow.
    """
    for attempt in range(MAX_REALLOCATIONS + 1):
        new_state, samples = _scan_chunk(simulation.step_fn, state, length)
        flags = int(new_state.flags)
        # Only a pure overflow is cured by larger buffers; with any other error the
        # configuration itself is broken and reallocating would only waste time.
        if flags == errors.NEIGHBOR_OVERFLOW and attempt < MAX_REALLOCATIONS:
            needs = new_state.pair_list
            minimum = (int(needs.needed_pairs), int(needs.needed_cell_occupancy))
            state = simulation.reallocate(state, minimum)
            continue
        if flags:
            raise errors.SimulationError(
                f"step {int(state.step)}–{int(state.step) + length}: {errors.describe(flags)} "
                f"(scene: integrator.dt = {simulation.scene.integrator.dt})"
            )
        return new_state, jax.tree.map(np.asarray, samples), attempt
    raise AssertionError("unreachable")


def run(
    simulation,
    state,
    steps: int,
    chunk: int,
    on_chunk: Callable[[ChunkResult], None] | None = None,
    on_error: Callable[[object, Exception], None] | None = None,
):
    """Run `steps` steps in chunks of `chunk`.

    Args:
        simulation: from `jaxdpd.simulation.build`.
        state: the start state.
        steps: number of steps (≥ 0).
        chunk: steps per jitted scan (≥ 1).
        on_chunk: called with each ChunkResult (writing output, progress, ...).
        on_error: called with (last good state, error) before the error propagates.
    Returns:
        The final state.
    """
    if steps < 0 or chunk < 1:
        raise ValueError(f"run: steps = {steps} must be ≥ 0 and chunk = {chunk} ≥ 1")
    scene = simulation.scene
    done = 0
    while done < steps:
        length = min(chunk, steps - done)
        try:
            new_state, samples, _ = run_chunk(simulation, state, length)
        except errors.SimulationError as error:
            if on_error is not None:
                on_error(state, error)
            raise
        series = reduce_samples(samples, scene.n_particles, scene.volume)
        if on_chunk is not None:
            on_chunk(ChunkResult(new_state, int(state.step), length, series))
        state = new_state
        done += length
    return state
