"""The chunked driver: overflow → reallocate and rerun; errors → message + checkpoint."""

import numpy as np
import pytest
from conftest import make_scene

from jaxdpd.engine.build import build
from jaxdpd.engine.errors import SimulationError
from jaxdpd.io.h5md import read_checkpoint
from jaxdpd.run import driver
from jaxdpd.run.runner import simulate


def test_overflowing_chunk_is_rerun_from_its_start_with_larger_buffers():
    """A chunk whose pair buffer is too small is rerun after reallocation: the final
    state equals that of a run that never overflowed (no step lost or repeated)."""
    scene = make_scene()
    simulation = build(scene)
    start = simulation.init_fn()
    reference = driver.run(simulation, start, 40, 20)
    small = start.pair_list.set(i=start.pair_list.i[:200], j=start.pair_list.j[:200])
    squeezed = start.set(pair_list=small)
    final, _, reallocations = driver.run_chunk(simulation, squeezed, 20)
    assert reallocations == 1
    assert final.pair_list.capacity > 200
    final = driver.run(simulation, final, 20, 20)
    assert int(final.step) == int(reference.step) == 40
    np.testing.assert_array_equal(final.positions, reference.positions)
    np.testing.assert_array_equal(final.velocities, reference.velocities)


def test_buffers_far_larger_than_needed_are_refitted_between_chunks():
    """Buffers grown to three times the cell occupancy (as after a random start) are
    refitted before the next chunk, and the trajectory is the one the oversized
    buffers give: refitting changes the work per step, not the pairs or their order."""
    simulation = build(make_scene())
    start = simulation.init_fn()
    occupancy = int(start.pair_list.needed_cell_occupancy)
    oversized = simulation.reallocate(start, (0, 3 * occupancy))
    assert oversized.pair_list.cell_capacity >= 3 * occupancy
    final = driver.run(simulation, oversized, 40, 20)
    assert final.pair_list.cell_capacity == simulation.fitted_shapes(oversized)[1]
    assert final.pair_list.cell_capacity < oversized.pair_list.cell_capacity
    (unfitted, _) = driver._scan_chunk(simulation.step_fn, oversized, 40)
    assert unfitted.pair_list.cell_capacity == oversized.pair_list.cell_capacity
    np.testing.assert_array_equal(final.positions, unfitted.positions)
    np.testing.assert_array_equal(final.velocities, unfitted.velocities)


def test_a_time_step_far_too_large_stops_with_a_message_and_a_checkpoint(tmp_path):
    scene = make_scene(integrator={"dt": 3.0}, run={"steps": 200, "chunk": 20})
    path = tmp_path / "unstable.h5"
    with pytest.raises(SimulationError, match=r"unstable.*integrator\.dt") as raised:
        simulate(scene, output_path=path, progress=False)
    assert "dt = 3.0" in str(raised.value)
    checkpoint = read_checkpoint(path)
    assert "unstable" in checkpoint["reason"]
    assert np.all(np.isfinite(checkpoint["positions"]))
    assert np.all(np.isfinite(checkpoint["velocities"]))
    assert checkpoint["step"] % 20 == 0  # the start of the failing chunk


def test_run_rejects_bad_arguments():
    simulation = build(make_scene())
    state = simulation.init_fn()
    with pytest.raises(ValueError, match="chunk"):
        driver.run(simulation, state, 10, 0)
