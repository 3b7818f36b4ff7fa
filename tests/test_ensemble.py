"""Ensembles: a vmapped sweep over shear rates and seeds is the same as the replicas
run one by one, and sharding the replica axis over devices changes nothing.

Reference: the replicas themselves, run separately with the same seeds (float64;
vmapping may reorder floating-point sums, so trajectories agree to round-off grown
over 40 steps, 1e-9, not bit for bit).
"""

import os
import subprocess
import sys
import textwrap
from pathlib import Path

import numpy as np
from conftest import make_scene

from jaxdpd.engine.build import build
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
    batch = ensemble.run(
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


SHARDED = textwrap.dedent(
    """
    import numpy as np, jax
    from conftest import make_scene
    from jaxdpd.run import ensemble
    from jaxdpd.engine.build import build
    from test_ensemble import RATES, SEEDS, sweep_scene
    assert jax.local_device_count() == 2, jax.local_devices()
    simulation = build(sweep_scene())
    start = simulation.init_fn()
    rates, seeds = RATES[1:], SEEDS[1:]
    batch = ensemble.replicate(simulation, start, seeds=seeds, shear_rates=rates)
    sharded = ensemble.run(simulation, batch, 40, 20)
    assert len(sharded.positions.sharding.device_set) == 2
    plain = ensemble.run(simulation, batch, 40, 20, over_devices=False)
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
