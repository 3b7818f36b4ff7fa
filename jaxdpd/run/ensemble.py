"""Ensembles: many replicas of one scene in one jitted, vmapped call.

A batch is a SimState whose every leaf has a leading replica axis B.  Replicas share
the scene's static structure (particle number, neighbour-buffer capacities) and may
differ in anything traced: seed (noise), initial configuration, flow rate (each
Lees–Edwards replica keeps its own offset, each Kraynik–Reinelt replica its own
strain), ...  A flow curve is one batch with one shear or elongation rate per
replica.

The batch axis is sharded over all local devices (`jax.sharding`) when B is a
multiple of the device count, so the same call uses every GPU, or every CPU device
of `XLA_FLAGS=--xla_force_host_platform_device_count=K`.

Error handling follows jaxdpd.run.driver: after each chunk the flags of all replicas are
read; an overflow anywhere reallocates every replica's buffers to the largest need
(shapes must stay common) and reruns the chunk; any other error stops the run,
naming the replicas.
"""

from collections.abc import Callable, Sequence
from functools import partial

import jax
import jax.numpy as jnp
import numpy as np
from jax.sharding import Mesh, NamedSharding, PartitionSpec

from jaxdpd.engine import errors
from jaxdpd.geometry import flows
from jaxdpd.observables import reduce_samples
from jaxdpd.run.driver import MAX_REALLOCATIONS, ChunkResult


def stack(states: Sequence) -> object:
    """Stack single-replica states into a batch (leading axis)."""
    return jax.tree.map(lambda *leaves: jnp.stack(leaves), *states)


def unstack(batch) -> list:
    """The replicas of a batch as single states."""
    count = jax.tree.leaves(batch)[0].shape[0]
    return [jax.tree.map(lambda leaf, k=k: leaf[k], batch) for k in range(count)]


def _common_buffers(simulation, states: list, minimum=None) -> list:
    """Reallocate every replica's neighbour buffers to one shape that holds all."""
    needs = minimum
    for _ in range(MAX_REALLOCATIONS + 1):
        states = [simulation.reallocate(s, needs) for s in states]
        if len({simulation.buffer_shapes(s) for s in states}) == 1:
            return states
        # Buffers differ in shape here, so the replicas cannot be stacked: the largest
        # need of each kind over the replicas.
        needs = tuple(np.max(v) for v in zip(*map(simulation.buffer_needs, states), strict=True))
    raise AssertionError("neighbour buffers of the replicas did not converge to one shape")


def replicate(
    simulation, state, count: int | None = None, seeds=None, flow_rates=None, shear_rates=None
):
    """A batch of replicas of `state` with their own seeds and flow rates.

    Args:
        simulation: from jaxdpd.engine.build.build.
        state: a single state (e.g. `simulation.init_fn()` or an equilibrated one),
            or a sequence of states (one per replica).
        count: number of replicas B (default: the length of seeds or the rates).
        seeds: B noise seeds (uint32); default: the state's seed plus 0, 1, ...
        flow_rates: B rates of the scene's flow: shear rates γ̇ ([flow] kind
            "shear") or elongation rates ε̇ (kind "planar_elongation").
        shear_rates: B shear rates γ̇, for a scene with a [flow] of kind "shear"
            (the same as flow_rates there).
    Returns:
        The batched SimState with buffers of one common shape.
    """
    flow = simulation.scene.flow
    if shear_rates is not None:
        if flow is None or flow.kind != "shear":
            raise ValueError("replicate: shear_rates need a scene with a [flow] of kind 'shear'")
        if flow_rates is not None:
            raise ValueError("replicate: give flow_rates or shear_rates, not both")
        flow_rates = shear_rates
    if flow_rates is not None and flow is None:
        raise ValueError("replicate: flow_rates need a scene with a [flow] section")
    states = list(state) if isinstance(state, (list, tuple)) else None
    if count is None:
        count = next(
            (len(x) for x in (states, seeds, flow_rates) if x is not None),
            None,
        )
    if count is None or count < 1:
        raise ValueError("replicate: give count ≥ 1, seeds or flow_rates")
    for name, values in (("seeds", seeds), ("flow rates", flow_rates), ("states", states)):
        if values is not None and len(values) != count:
            raise ValueError(f"replicate: {len(values)} {name} for {count} replicas")
    states = states or [state] * count
    if seeds is None:
        seeds = [int(states[0].seed) + k for k in range(count)]
    replicas = []
    for k, replica in enumerate(states):
        replica = replica.set(seed=jnp.asarray(seeds[k], jnp.uint32))
        if flow_rates is not None:
            replica = flows.set_flow_rate(replica, flow.kind, flow_rates[k])
        replicas.append(replica)
    return stack(_common_buffers(simulation, replicas))


def batch_sharding(count: int):
    """NamedSharding of a leading replica axis over all local devices, or None when
    the count does not divide evenly (the batch then stays on one device)."""
    devices = jax.local_devices()
    if len(devices) < 2 or count % len(devices):
        return None
    return NamedSharding(Mesh(np.asarray(devices), ("replica",)), PartitionSpec("replica"))


def shard(batch):
    """Place a batch with its replica axis spread over the local devices."""
    count = jax.tree.leaves(batch)[0].shape[0]
    sharding = batch_sharding(count)
    if sharding is None:
        return batch
    return jax.tree.map(lambda leaf: jax.device_put(leaf, sharding), batch)


@partial(jax.jit, static_argnums=(0, 2))
def _scan_batch(step_fn, batch, length: int):
    def scan_one(state):
        return jax.lax.scan(lambda carry, _: step_fn(carry), state, None, length=length)

    return jax.vmap(scan_one)(batch)


def run_chunk(simulation, batch, length: int):
    """Advance every replica `length` steps (reallocating on overflow).

    Returns:
        (new batch, per-step samples (B, length, ...) as NumPy arrays).
    Raises:
        SimulationError: naming the replicas whose flags show any other error.
    """
    for attempt in range(MAX_REALLOCATIONS + 1):
        new_batch, samples = _scan_batch(simulation.step_fn, batch, length)
        flags = np.asarray(new_batch.flags)
        overflowed = (flags & errors.NEIGHBOR_OVERFLOW) != 0
        broken = (flags & ~errors.NEIGHBOR_OVERFLOW) != 0
        if overflowed.any() and not broken.any() and attempt < MAX_REALLOCATIONS:
            minimum = simulation.buffer_needs(new_batch)
            resized = stack(_common_buffers(simulation, unstack(batch), minimum))
            batch = shard(resized) if batch_sharding(len(flags)) is not None else resized
            continue
        if flags.any():
            first = int(np.asarray(batch.step)[0])
            described = "; ".join(
                f"replica {k}: {errors.describe(int(f))}" for k, f in enumerate(flags) if f
            )
            raise errors.SimulationError(
                f"step {first}–{first + length}: {described} "
                f"(scene: integrator.dt = {simulation.scene.integrator.dt})"
            )
        return new_batch, jax.tree.map(np.asarray, samples)
    raise AssertionError("unreachable")


def run(
    simulation,
    batch,
    steps: int,
    chunk: int,
    on_chunk: Callable[[ChunkResult], None] | None = None,
    over_devices: bool = True,
):
    """Run every replica of `batch` for `steps` steps in chunks.

    Args:
        on_chunk: receives ChunkResults whose state is the batch and whose series
            have a leading replica axis (B, chunk, ...).
        over_devices: shard the replica axis over all local devices (see `shard`).
    Returns:
        The final batch.
    """
    if steps < 0 or chunk < 1:
        raise ValueError(f"run: steps = {steps} must be ≥ 0 and chunk = {chunk} ≥ 1")
    scene = simulation.scene
    if over_devices:
        batch = shard(batch)
    done = 0
    while done < steps:
        length = min(chunk, steps - done)
        first = int(np.asarray(batch.step)[0])
        batch, samples = run_chunk(simulation, batch, length)
        series = reduce_samples(samples, scene)
        if on_chunk is not None:
            on_chunk(ChunkResult(batch, first, length, series))
        done += length
    return batch
