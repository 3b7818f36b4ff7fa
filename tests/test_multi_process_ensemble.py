"""Multi-process ensembles: two processes on this machine, joined by JAX's distributed
runtime (a local coordinator on the loopback interface, gloo collectives), run one
sweep of 2 seeds × 2 shear rates, each process its block of two replicas, and every
process gathers the whole sweep; it equals the single-process batch of the same four
replicas (`driver.run` on `ensemble.replicate`), bit for bit.

Why bit for bit, not to round-off: a replica's arithmetic is the same in both runs.
vmap gives every operation a leading replica axis and no operation reduces over it;
that axis is the outermost dimension of every array, so a replica's elements lie in
the same layout in a batch of two (a process's block) as in a batch of four, and
XLA's CPU kernels form each replica's sums over the same elements in the same order.
The noise is counter-based, (seed, step, i, j), and every replica starts from the
same state, so its neighbour buffers get the same capacity in either batch.  (A
batch against an unbatched run is another kernel and differs in round-off,
tests/test_ensemble.py.)  Were an XLA version to tile a kernel by the batch size,
this test would say so, and test_ensemble's round-off bound would be the one to
use; on GPUs, where reductions may be tiled by the total size, expect round-off.

The runtime is skipped only when the processes cannot join it at all (no loopback
TCP); any later failure fails the test.
"""

import os
import signal
import subprocess
import sys
import textwrap
from pathlib import Path

import numpy as np
import pytest
from conftest import make_scene

from jaxdpd.engine.build import build
from jaxdpd.io.checkpoint import read_checkpoint_info
from jaxdpd.io.reader import read_scene, read_trajectory
from jaxdpd.run import distributed, driver, ensemble, launch

SEEDS = [31, 31, 32, 32]
RATES = [0.2, 0.5, 0.2, 0.5]
STEPS, CHUNK = 40, 20
UNAVAILABLE = 77  # a process's exit status when it could not join the runtime


def sweep_scene():
    return make_scene(
        particles={"density": 3.0, "count": 300},
        flow={"kind": "shear", "shear_rate": 0.0},
        output={"observables": ["temperature", "pressure"], "trajectory_every": STEPS},
        run={"steps": STEPS, "chunk": CHUNK},
    )


PROCESS = textwrap.dedent(
    """
    import sys
    from pathlib import Path
    from jaxdpd.run import distributed
    try:
        distributed.initialize(timeout=30)
    except Exception as error:
        print("cannot join the distributed runtime:", error, file=sys.stderr)
        sys.exit(UNAVAILABLE)
    import jax, numpy as np
    from jaxdpd.engine.build import build
    from test_multi_process_ensemble import CHUNK, RATES, SEEDS, STEPS, sweep_scene
    assert jax.process_count() == 2 and jax.local_device_count() == 1
    directory, process = Path(sys.argv[1]), jax.process_index()
    simulation = build(sweep_scene())
    start = simulation.init_fn()
    result = distributed.sweep(
        simulation, start, STEPS, CHUNK, SEEDS, RATES, directory / "sweep", keep_series=True
    )
    np.savez(
        directory / f"gathered_{process}.npz",
        positions=np.stack([s.positions for s in result.states]),
        velocities=np.stack([s.velocities for s in result.states]),
        offset=np.stack([s.box_state.offset for s in result.states]),
        step=np.stack([s.step for s in result.states]),
        owners=result.owners,
        **{f"series_{n}": v for n, v in result.series.items()},
        **{f"mean_{n}": v for n, v in result.means.items()},
    )
    # A stop requested in process 1 only, before its second chunk: both processes
    # raise the same SweepError instead of waiting for each other.
    asked = []
    def stop():
        asked.append(1)
        return "SIGTERM" if process == 1 and len(asked) == 2 else None
    try:
        distributed.sweep(simulation, start, STEPS, CHUNK, SEEDS, RATES, directory / "stopped",
                          should_stop=stop)
    except distributed.SweepError as error:
        (directory / f"stopped_{process}.txt").write_text(str(error))
    # Every replica fails in its first chunk: the sweep's replica numbers in the error.
    broken = start.set(velocities=start.velocities.at[0, 0].set(np.nan))
    try:
        distributed.sweep(simulation, broken, STEPS, CHUNK, SEEDS, RATES)
    except distributed.SweepError as error:
        (directory / f"failed_{process}.txt").write_text(str(error))
    """
).replace("UNAVAILABLE", str(UNAVAILABLE))


def start_two_processes(directory: Path) -> list:
    """Launch the sweep in two processes (children of this one, PIPEs to read)."""
    tests = Path(__file__).parent
    environment = {
        **os.environ,
        "PYTHONPATH": os.pathsep.join(
            [str(tests), str(tests.parent), os.environ.get("PYTHONPATH", "")]
        ),
    }
    environment.pop("XLA_FLAGS", None)  # one CPU device per process
    return launch.launch(
        [sys.executable, "-c", PROCESS, str(directory)],
        2,
        env=environment,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )


def finish(children, directory: Path) -> list:
    """Wait for the processes; their gathered results (process order)."""
    outputs = [child.communicate(timeout=300) for child in children]
    codes = [child.returncode for child in children]
    if UNAVAILABLE in codes:
        pytest.skip(f"the JAX distributed runtime cannot start here: {outputs[0][1][-500:]}")
    for code, (_, errors) in zip(codes, outputs, strict=True):
        assert code == 0, errors[-3000:]
    return [dict(np.load(directory / f"gathered_{k}.npz")) for k in range(2)]


def test_two_process_sweep_equals_the_single_process_batch_bit_for_bit(tmp_path):
    children = start_two_processes(tmp_path)
    # The reference, while the two processes run: the one-process batch of all four.
    simulation = build(sweep_scene())
    batch = ensemble.replicate(simulation, simulation.init_fn(), seeds=SEEDS, flow_rates=RATES)
    chunks = []
    final = driver.run(simulation, batch, STEPS, CHUNK, on_chunk=lambda r: chunks.append(r.series))
    series = {n: np.concatenate([c[n] for c in chunks], axis=1) for n in chunks[0]}
    gathered = finish(children, tmp_path)
    for result in gathered:  # every process holds the whole sweep
        np.testing.assert_array_equal(result["owners"], [0, 0, 1, 1])
        np.testing.assert_array_equal(result["positions"], final.positions)
        np.testing.assert_array_equal(result["velocities"], final.velocities)
        np.testing.assert_array_equal(result["offset"], final.box_state.offset)
        np.testing.assert_array_equal(result["step"], [STEPS] * 4)
        for name, values in series.items():
            np.testing.assert_array_equal(result[f"series_{name}"], values)
            # The means are summed chunk by chunk on the host, in another order than
            # NumPy's mean: a sum of STEPS terms differs by at most STEPS ulps of the
            # mean of their magnitudes.
            bound = STEPS * np.finfo(values.dtype).eps * np.abs(values).mean(axis=1)
            assert np.all(np.abs(result[f"mean_{name}"] - values.mean(axis=1)) <= bound)
    assert len(np.unique(gathered[0]["offset"])) == 2  # the two shear rates differ
    # One file per replica, written by its owner: the replica's scene and frame.
    for k, (seed, rate) in enumerate(zip(SEEDS, RATES, strict=True)):
        path = distributed.replica_path(tmp_path / "sweep", k)
        scene = read_scene(path)
        assert (scene.seed, scene.flow.shear_rate) == (seed, rate)
        frames = read_trajectory(path)
        np.testing.assert_array_equal(frames.step, [STEPS])
        np.testing.assert_array_equal(frames.value[-1], final.positions[k])
        assert read_checkpoint_info(path).reason == "end of run"
    # The stop in process 1: the same error on both, each replica checkpointed by
    # its owner where its block stopped.
    messages = [(tmp_path / f"stopped_{k}.txt").read_text() for k in range(2)]
    assert messages[0] == messages[1]
    assert messages[0].startswith("process 1 (replicas 2–3") and "SIGTERM" in messages[0]
    reasons = [
        read_checkpoint_info(distributed.replica_path(tmp_path / "stopped", k)) for k in range(4)
    ]
    assert [info.step for info in reasons] == [STEPS, STEPS, CHUNK, CHUNK]
    failed = [(tmp_path / f"failed_{k}.txt").read_text() for k in range(2)]
    assert failed[0] == failed[1]
    assert failed[0].startswith("process 0 (replicas 0–1): SimulationError: step 0–20: replica 0")
    assert "process 1 (replicas 2–3): SimulationError: step 0–20: replica 2: " in failed[0]
    assert "replica 3: " in failed[0]


def test_replicas_are_shared_out_in_contiguous_blocks():
    blocks = [distributed.share(7, p, 3) for p in range(3)]
    assert [list(b) for b in blocks] == [[0, 1, 2], [3, 4], [5, 6]]
    assert list(distributed.share(2, 1, 2)) == [1]


def test_the_launcher_numbers_the_processes_and_stops_the_rest_after_a_failure():
    """Process 1 fails at once, process 0 would sleep a minute: the launcher returns
    the failure's status and terminates process 0 after the grace period."""
    code = (
        "import os, sys, time\n"
        "k = int(os.environ['JAXDPD_PROCESS_ID'])\n"
        "print(os.environ['JAXDPD_COORDINATOR'], os.environ['JAXDPD_PROCESS_COUNT'], k)\n"
        "sys.exit(5) if k else time.sleep(60)\n"
    )
    children = launch.launch([sys.executable, "-c", code], 2, stdout=subprocess.PIPE, text=True)
    assert launch.wait(children, grace=0.5) == 5
    assert children[0].returncode == -signal.SIGTERM
    lines = [child.stdout.read().split() for child in children]
    assert lines[0][0] == lines[1][0] and lines[0][0].startswith("127.0.0.1:")
    assert [line[1:] for line in lines] == [["2", "0"], ["2", "1"]]
