"""Ensembles: a vmapped sweep over shear rates and seeds, run through the one driver,
is the same as the replicas run one by one; sharding the replica axis over devices
changes nothing; the driver's overflow reallocation, error flags and stop requests
work on a batch as on a single state.

Reference: the replicas themselves, run separately with the same seeds (float64;
vmapping may reorder floating-point sums, so trajectories agree to round-off grown
over 40 steps, 1e-9, not bit for bit).
"""

import os
import signal
import subprocess
import sys
import textwrap
from pathlib import Path

import jax.numpy as jnp
import numpy as np
import pytest
from conftest import make_scene

from jaxdpd.engine.build import build
from jaxdpd.engine.errors import SimulationError
from jaxdpd.run import driver, ensemble

RATES = [0.0, 0.3, 0.6]
SEEDS = [21, 22, 23]


def sweep_scene():
    return make_scene(
        particles={"density": 3.0, "count": 300},
        flow={"kind": "shear", "shear_rate": 0.0},
        run={"steps": 40, "chunk": 20},
    )


def test_vmapped_sweep_equals_replicas_run_one_by_one():
    simulation = build(sweep_scene())
    start = simulation.init_fn()
    batch = ensemble.replicate(simulation, start, seeds=SEEDS, shear_rates=RATES)
    stress = []
    batch = driver.run(
        simulation, batch, 40, 20, on_chunk=lambda r: stress.append(r.series["pressure_tensor"])
    )
    stress = np.concatenate(stress, axis=1)
    for k, (rate, seed) in enumerate(zip(RATES, SEEDS, strict=True)):
        single = ensemble.unstack(
            ensemble.replicate(simulation, start, seeds=[seed], shear_rates=[rate])
        )[0]
        alone = []
        single = driver.run(
            simulation,
            single,
            40,
            20,
            on_chunk=lambda r, kept=alone: kept.append(r.series["pressure_tensor"]),
        )
        np.testing.assert_allclose(np.asarray(batch.positions[k]), single.positions, atol=1e-9)
        np.testing.assert_allclose(np.asarray(batch.velocities[k]), single.velocities, atol=1e-9)
        np.testing.assert_allclose(stress[k], np.concatenate(alone), atol=1e-9)
        assert float(batch.box_state.offset[k]) == float(single.box_state.offset)
    offsets = np.asarray(batch.box_state.offset)
    assert offsets[0] == 0.0 and offsets[1] != offsets[2]  # each replica its own offset


def sweep_batch():
    simulation = build(sweep_scene())
    batch = ensemble.replicate(simulation, simulation.init_fn(), seeds=SEEDS, shear_rates=RATES)
    return simulation, batch


def test_an_overflowing_batch_is_rerun_with_every_replica_sized_for_the_largest_need():
    simulation, batch = sweep_batch()
    reference = driver.run(simulation, batch, 20, 20)
    pairs = batch.pair_list
    squeezed = batch.set(pair_list=pairs.set(i=pairs.i[:, :200], j=pairs.j[:, :200]))
    final, _, reallocations = driver.run_chunk(simulation, squeezed, 20)
    assert reallocations == 1
    assert final.pair_list.i.shape[1] > 200  # one common capacity for all replicas
    np.testing.assert_array_equal(final.positions, reference.positions)
    np.testing.assert_array_equal(final.velocities, reference.velocities)


def test_a_batch_names_the_replicas_that_failed_and_hands_on_its_last_good_state():
    simulation, batch = sweep_batch()
    broken = batch.set(velocities=batch.velocities.at[1, 0, 0].set(jnp.nan))
    handed = []
    with pytest.raises(SimulationError, match=r"step 0–20: replica 1: ") as raised:
        driver.run(simulation, broken, 40, 20, on_error=lambda state, _: handed.append(state))
    assert "replica 0" not in str(raised.value) and "replica 2" not in str(raised.value)
    (state,) = handed
    np.testing.assert_array_equal(state.step, [0, 0, 0])
    np.testing.assert_array_equal(state.positions, broken.positions)


def test_a_signal_stops_a_batch_after_the_chunk_in_flight_and_it_runs_on_unchanged():
    """SIGTERM during a batch run stops it at the next chunk boundary with the batch
    after that chunk; running on from it gives the uninterrupted run's batch."""
    simulation, batch = sweep_batch()
    reference = driver.run(simulation, batch, 40, 20)
    with driver.SignalGuard() as guard:
        with pytest.raises(driver.RunInterrupted, match="SIGTERM at step 20") as raised:
            driver.run(
                simulation,
                batch,
                40,
                20,
                on_chunk=lambda _: os.kill(os.getpid(), signal.SIGTERM),
                should_stop=guard,
            )
    stopped = raised.value.state
    np.testing.assert_array_equal(stopped.step, [20, 20, 20])
    final = driver.run(simulation, stopped, 20, 20)
    np.testing.assert_array_equal(final.positions, reference.positions)
    np.testing.assert_array_equal(final.velocities, reference.velocities)


SHARDED = textwrap.dedent(
    """
    import numpy as np, jax
    from conftest import make_scene
    from jaxdpd.run import driver, ensemble
    from jaxdpd.engine.build import build
    from test_ensemble import RATES, SEEDS, sweep_scene
    assert jax.local_device_count() == 2, jax.local_devices()
    simulation = build(sweep_scene())
    start = simulation.init_fn()
    rates, seeds = RATES[1:], SEEDS[1:]
    batch = ensemble.replicate(simulation, start, seeds=seeds, shear_rates=rates)
    sharded = driver.run(simulation, batch, 40, 20)
    assert len(sharded.positions.sharding.device_set) == 2
    plain = driver.run(simulation, batch, 40, 20, over_devices=False)
    assert len(plain.positions.sharding.device_set) == 1
    difference = np.abs(np.asarray(sharded.positions) - np.asarray(plain.positions)).max()
    print("difference", float(difference))
    """
)


def test_sharded_sweep_equals_unsharded_sweep():
    """Two CPU devices (XLA_FLAGS=--xla_force_host_platform_device_count=2): the
    replicas are split over them and give the same trajectories."""
    tests = Path(__file__).parent
    environment = {
        **os.environ,
        "XLA_FLAGS": "--xla_force_host_platform_device_count=2",
        "PYTHONPATH": os.pathsep.join(
            [str(tests), str(tests.parent), os.environ.get("PYTHONPATH", "")]
        ),
    }
    result = subprocess.run(
        [sys.executable, "-c", SHARDED],
        env=environment,
        capture_output=True,
        text=True,
        timeout=600,
    )
    assert result.returncode == 0, result.stderr[-3000:]
    difference = float(result.stdout.split("difference")[-1])
    assert difference < 1e-9
