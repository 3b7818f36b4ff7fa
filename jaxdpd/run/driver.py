"""The run driver: jitted `lax.scan` chunks, error checks between chunks.

One loop runs a single state or a batch of replicas (every leaf with a leading
replica axis, made by jaxdpd.run.ensemble), the batch vmapped over that axis in one
jitted call.  After every chunk the driver reads the error flags (of every replica):
- neighbour overflow: the buffers are reallocated from the needs the chunk recorded
  (a batch's replicas all to its largest need, so their shapes stay common) and the
  chunk is rerun from its saved start state (no step lost or duplicated);
- buffers far larger than the state needs (sized for a random start, whose
  ideal-gas density fluctuations a liquid soon loses): when a buffer's fitted size
  (`simulation.fitted_shapes`) is at most `SHRINK_BELOW` of its size, the buffers are
  refitted to the state before the next chunk (one recompilation; checked before
  every chunk, so a run continued by repeated calls is refitted too), and no run
  keeps paying for its start;
- anything else (non-finite values, ...): the last good state (the chunk's start)
  is handed to `on_error` (e.g. written as a checkpoint) and `SimulationError` is
  raised with a message saying what went wrong (in which replicas) and what to change.

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
from jaxdpd.run import ensemble

MAX_REALLOCATIONS = 8
# Refit when a buffer would shrink to this fraction of its size or less: the saving
# then outweighs a recompilation within a few chunks, and a liquid's fluctuations,
# mostly inside a fit's head room, seldom make refits alternate with overflows.
SHRINK_BELOW = 0.75


@dataclass
class ChunkResult:
    """What one chunk produced (host-side NumPy): the state (or batch) after it, its
    first step, its length and its series (a batch's with a leading replica axis,
    (B, steps, ...))."""

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
        super().__init__(f"interrupted by {signal_name} at step {first_step(state)}")
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


def first_step(state) -> int:
    """The step counter of a state, or of a batch (its replicas step together)."""
    return int(np.asarray(state.step).reshape(-1)[0])


@partial(jax.jit, static_argnums=(0, 2))
def _scan_chunk(step_fn, state, length: int):
    return jax.lax.scan(lambda carry, _: step_fn(carry), state, None, length=length)


@partial(jax.jit, static_argnums=(0, 2))
def _scan_batch(step_fn, batch, length: int):
    def scan_one(state):
        return jax.lax.scan(lambda carry, _: step_fn(carry), state, None, length=length)

    return jax.vmap(scan_one)(batch)


def _reallocate(simulation, state, needs):
    """Buffers for `needs`; a batch's replicas all get its largest need (one shape),
    and keep the batch's placement over devices."""
    if not ensemble.is_batch(state):
        return simulation.reallocate(state, needs)
    replicas = ensemble.common_buffers(simulation, ensemble.unstack(state), needs)
    resized = ensemble.stack(replicas)
    sharded = len(state.positions.sharding.device_set) > 1
    return ensemble.shard(resized) if sharded else resized


def _oversized(simulation, state) -> bool:
    """True when some neighbour buffer (of any replica of a batch) would fit in at
    most SHRINK_BELOW of its size."""
    replicas = ensemble.unstack(state) if ensemble.is_batch(state) else [state]
    fitted = np.max([simulation.fitted_shapes(replica) for replica in replicas], axis=0)
    shapes = np.asarray(simulation.buffer_shapes(replicas[0]))
    return bool(np.any(fitted <= SHRINK_BELOW * shapes))


def _describe(flags: np.ndarray) -> str:
    """The error flags of a state, or of a batch's failed replicas by index."""
    if flags.ndim == 0:
        return errors.describe(int(flags))
    return "; ".join(f"replica {k}: {errors.describe(int(f))}" for k, f in enumerate(flags) if f)


def run_chunk(simulation, state, length: int):
    """Advance a state or a batch `length` steps, reallocating buffers on overflow.

    Returns:
        (new state, per-step samples as NumPy arrays (a batch's (B, length, ...)),
        number of reallocations).
    Raises:
        SimulationError: on any error flag other than a neighbour overflow (naming
            the replicas of a batch that set one).
    """
    scan = _scan_batch if ensemble.is_batch(state) else _scan_chunk
    for attempt in range(MAX_REALLOCATIONS + 1):
        new_state, samples = scan(simulation.step_fn, state, length)
        flags = np.asarray(new_state.flags)
        # Only a pure overflow is cured by larger buffers; with any other error the
        # configuration itself is broken and reallocating would only waste time.
        broken = (flags & ~errors.StepError.NEIGHBOR_OVERFLOW) != 0
        if flags.any() and not broken.any() and attempt < MAX_REALLOCATIONS:
            state = _reallocate(simulation, state, simulation.buffer_needs(new_state))
            continue
        if flags.any():
            first = first_step(state)
            raise errors.SimulationError(
                f"step {first}–{first + length}: {_describe(flags)} "
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
    over_devices: bool = True,
):
    """Run a state, or every replica of a batch, `steps` steps in chunks of `chunk`.

    Args:
        simulation: from `jaxdpd.engine.build.build`.
        state: the start state, or a batch (jaxdpd.run.ensemble.replicate).
        steps: number of steps (≥ 0).
        chunk: steps per jitted scan (≥ 1).
        on_chunk: called with each ChunkResult (writing output, progress, ...).
        on_error: called with (last good state, error) before the error propagates.
        should_stop: asked before each chunk; a non-empty answer (the reason, e.g. a
            signal name) stops the run.
        over_devices: spread a batch's replica axis over all local devices
            (jaxdpd.run.ensemble.shard); no effect on a single state.
    Returns:
        The final state (or batch).
    Raises:
        SimulationError: a chunk set an error flag (see the module docstring).
        RunInterrupted: `should_stop` asked for a stop; carries the current state.
    """
    if steps < 0 or chunk < 1:
        raise ValueError(f"run: steps = {steps} must be ≥ 0 and chunk = {chunk} ≥ 1")
    scene = simulation.scene
    if over_devices and ensemble.is_batch(state):
        state = ensemble.shard(state)
    done = 0
    while done < steps:
        reason = should_stop() if should_stop is not None else None
        if reason:
            raise RunInterrupted(state, reason)
        length = min(chunk, steps - done)
        if _oversized(simulation, state):
            state = _reallocate(simulation, state, None)
        try:
            new_state, samples, _ = run_chunk(simulation, state, length)
        except errors.SimulationError as error:
            if on_error is not None:
                on_error(state, error)
            raise
        series = reduce_samples(samples, scene)
        if on_chunk is not None:
            on_chunk(ChunkResult(new_state, first_step(state), length, series))
        state = new_state
        done += length
    return state
