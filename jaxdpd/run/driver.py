"""The run driver: jitted `lax.scan` chunks, error checks between chunks.

After every chunk the driver reads the state's error flags:
- neighbour overflow: the buffers are reallocated from the needs the chunk recorded
  and the chunk is rerun from its saved start state (no step lost or duplicated);
- anything else (non-finite values, ...): the last good state (the chunk's start)
  is handed to `on_error` (e.g. written as a checkpoint) and `SimulationError` is
  raised with a message saying what went wrong and what to change.

Before each chunk the driver asks `should_stop()`; a stop request (e.g. from
`SignalGuard`, which turns SIGINT and SIGTERM into one) raises `RunInterrupted`
carrying the state after the last finished chunk, so no step is lost.
"""

import os
import signal
import threading
from collections.abc import Callable
from dataclasses import dataclass
from functools import partial

import jax
import numpy as np

from jaxdpd.engine import errors
from jaxdpd.observables import reduce_samples

MAX_REALLOCATIONS = 8


@dataclass
class ChunkResult:
    """What one chunk produced (host-side NumPy)."""

    state: object
    first_step: int
    steps: int
    series: dict


class RunInterrupted(Exception):
    """A run stopped between chunks because a stop was requested.

    Attributes:
        state: the state after the last finished chunk.
        signal_name: what asked for the stop (e.g. "SIGINT").
    """

    def __init__(self, state, signal_name: str):
        super().__init__(f"interrupted by {signal_name} at step {int(state.step)}")
        self.state = state
        self.signal_name = signal_name


class SignalGuard:
    """While active, SIGINT and SIGTERM ask the run to stop at the next chunk boundary.

    The first signal only records the request (`requested` becomes its name) and
    prints a notice on stderr; it also sets both signals to their default action, so
    a second one terminates the process at once, even in the middle of a chunk
    (without a checkpoint: the file keeps the last one written).  Leaving the guard
    restores the previous handlers.  Signals that were ignored are handled too: a job
    started in the background by a non-interactive shell inherits an ignored SIGINT,
    and `kill -INT` should still stop it with a checkpoint.  Outside the main thread
    (where Python cannot install handlers) the guard does nothing.

    Example:
        with SignalGuard() as guard:
            state = driver.run(simulation, state, steps, chunk, should_stop=guard)
    """

    SIGNALS = (signal.SIGINT, signal.SIGTERM)

    def __init__(self):
        self.requested: str | None = None
        self._previous: dict = {}

    def __call__(self) -> str | None:
        """The name of the signal that asked for a stop, or None."""
        return self.requested

    def _handle(self, signum, _frame) -> None:
        self.requested = signal.Signals(signum).name
        for guarded in self._previous:
            signal.signal(guarded, signal.SIG_DFL)
        # os.write: a signal handler must not re-enter a buffered stream.
        os.write(
            2,
            f"\njaxdpd: {self.requested} received: finishing the chunk in flight, then "
            "writing a checkpoint (send it again to stop at once, without one)\n".encode(),
        )

    def __enter__(self) -> "SignalGuard":
        if threading.current_thread() is threading.main_thread():
            for signum in self.SIGNALS:
                self._previous[signum] = signal.getsignal(signum)
                signal.signal(signum, self._handle)
        return self

    def __exit__(self, *exc) -> None:
        for signum, handler in self._previous.items():
            signal.signal(signum, handler)
        self._previous = {}


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
            state = simulation.reallocate(state, simulation.buffer_needs(new_state))
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
    should_stop: Callable[[], str | None] | None = None,
):
    """Run `steps` steps in chunks of `chunk`.

    Args:
        simulation: from `jaxdpd.engine.build.build`.
        state: the start state.
        steps: number of steps (≥ 0).
        chunk: steps per jitted scan (≥ 1).
        on_chunk: called with each ChunkResult (writing output, progress, ...).
        on_error: called with (last good state, error) before the error propagates.
        should_stop: asked before each chunk; a non-empty answer (the reason, e.g. a
            signal name) stops the run.
    Returns:
        The final state.
    Raises:
        SimulationError: a chunk set an error flag (see the module docstring).
        RunInterrupted: `should_stop` asked for a stop; carries the current state.
    """
    if steps < 0 or chunk < 1:
        raise ValueError(f"run: steps = {steps} must be ≥ 0 and chunk = {chunk} ≥ 1")
    scene = simulation.scene
    done = 0
    while done < steps:
        reason = should_stop() if should_stop is not None else None
        if reason:
            raise RunInterrupted(state, reason)
        length = min(chunk, steps - done)
        try:
            new_state, samples, _ = run_chunk(simulation, state, length)
        except errors.SimulationError as error:
            if on_error is not None:
                on_error(state, error)
            raise
        series = reduce_samples(samples, scene)
        if on_chunk is not None:
            on_chunk(ChunkResult(new_state, int(state.step), length, series))
        state = new_state
        done += length
    return state
