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

A batch runs through the same loop as a single state, `jaxdpd.run.driver.run`
(vmapped over the replica axis, with the same overflow reallocation, error flags,
checkpoint hooks and stop requests); this module only makes and takes apart batches.
"""

from collections.abc import Sequence

import jax
import jax.numpy as jnp
import numpy as np
from jax.sharding import Mesh, NamedSharding, PartitionSpec

from jaxdpd.geometry import flows

# Rounds of reallocation before the replicas' neighbour buffers must agree in shape
# (each round sizes every replica for the largest need of the round before).
MAX_SHAPE_ROUNDS = 8


def is_batch(state) -> bool:
    """Whether `state` is a batch (its step counter has a replica axis)."""
    return jnp.ndim(state.step) == 1


def stack(states: Sequence) -> object:
    """Stack single-replica states into a batch (leading axis)."""
    return jax.tree.map(lambda *leaves: jnp.stack(leaves), *states)


def unstack(batch) -> list:
    """The replicas of a batch as single states."""
    count = jax.tree.leaves(batch)[0].shape[0]
    return [jax.tree.map(lambda leaf, k=k: leaf[k], batch) for k in range(count)]


def common_buffers(simulation, states: list, minimum=None) -> list:
    """Reallocate every replica's neighbour buffers to one shape that holds all.

    Args:
        simulation: from jaxdpd.engine.build.build.
        states: single-replica states.
        minimum: buffer needs to hold at least (`simulation.buffer_needs` of a batch
            after an overflow: its largest need of each kind is taken); None fits
            each replica's own configuration first.
    """
    needs = minimum
    for _ in range(MAX_SHAPE_ROUNDS + 1):
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
    return stack(common_buffers(simulation, replicas))


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
