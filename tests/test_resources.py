"""Resource limits (issue 28, items 8–9): the scenes of the issue that ended in NumPy
memory errors, int32 overflows or hangs are refused by `build()` with a ValueError
naming the field, before anything is allocated (jaxdpd.run.resources), and a random
placement that cannot finish gives up (jaxdpd.geometry.placement)."""

import time

import jax.numpy as jnp
import pytest
from conftest import scene_dict
from test_lattice_boltzmann_scene import lattice_scene

from jaxdpd.engine.build import build, chain_blocks
from jaxdpd.geometry import placement
from jaxdpd.geometry.boxes.periodic import PeriodicBox
from jaxdpd.run import driver
from jaxdpd.run.resources import ResourceError, check_resources, estimated_bytes
from jaxdpd.scene import Scene


def _scene(drop_density=False, **sections) -> Scene:
    data = scene_dict(**sections)
    if drop_density:
        del data["particles"]["density"]
    return Scene.from_dict(data)


ISSUE_SCENES = [
    # (sections, error, words in the message)
    ({"particles": {"count": 10**9}}, ResourceError, ["particles.count", "GiB"]),
    (
        {"output": {"observables": ["rdf"], "rdf_bins": 10**12, "rdf_max": 2.0}},
        ValueError,
        ["output.rdf_bins", "2147483647"],
    ),
    (
        {"output": {"observables": ["profile"], "profile_bins": 10**9}},
        ResourceError,
        ["output.profile_bins", "GiB"],
    ),
    # Memory (280 GiB) on most machines; the int32 bound below.
    ({"neighbors": {"capacity_multiplier": 1e7}}, ResourceError, ["capacity_multiplier"]),
    ({"run": {"steps": 2**31}}, ValueError, ["run.steps", "2147483647"]),
    ({"run": {"steps": 2**30, "equilibration": 2**30 + 5}}, ResourceError, ["run.equilibration"]),
    ({"run": {"steps": 2**30, "chunk": 2**30}}, ResourceError, ["run.chunk", "GiB"]),
    # |γ̇| L_y Δt = 1e3 · 5.85 · 0.04 ≫ L_x / 2.
    ({"flow": {"kind": "shear", "shear_rate": -1e3}}, ResourceError, ["flow.shear_rate"]),
]


@pytest.mark.parametrize(("sections", "error", "words"), ISSUE_SCENES)
def test_issue_scenes_are_refused_by_name_before_allocation(sections, error, words):
    start = time.perf_counter()
    with pytest.raises(error) as caught:
        build(_scene(drop_density="box" in sections, **sections))
    assert time.perf_counter() - start < 5
    for word in words:
        assert word in str(caught.value)


def test_a_box_too_long_for_cells_of_the_cutoff_runs_on_larger_cells():
    """A box of 10³⁰⁰ × 6 × 6 (found by fuzzing) would need 10³⁰⁰ cells of edge r_c: it
    overflowed int32 in the cell list, then was refused for memory. The cell grid is
    now capped at 4 N cells (jaxdpd.geometry.neighbors.cell_list.cell_grid), so the
    scene, 600 particles that never meet, builds in seconds and runs unflagged."""
    start = time.perf_counter()
    simulation = build(_scene(drop_density=True, box={"lengths": [1e300, 6.0, 6.0]}))
    state = driver.run(simulation, simulation.init_fn(), 20, 10)
    assert time.perf_counter() - start < 60
    assert int(state.flags) == 0
    assert bool(jnp.all(jnp.isfinite(state.velocities)))


def test_pair_buffer_beyond_int32_is_refused_whatever_the_memory():
    scene = _scene(neighbors={"capacity_multiplier": 1e7})
    with pytest.raises(ResourceError, match=r"capacity_multiplier = 1e\+07: .* int32"):
        check_resources(scene, PeriodicBox(scene.box.lengths), available=2**62)


def test_crowded_cells_are_refused_instead_of_hanging_in_the_cell_list():
    crowded = {"particles": {"count": 3000}, "box": {"lengths": [2.1, 2.1, 2.1]}}
    with pytest.raises(ResourceError, match=r"particles.count = 3000 .* per neighbour cell"):
        build(_scene(drop_density=True, **crowded))


def test_memory_bound_compares_with_what_is_available():
    scene = _scene()
    box = PeriodicBox(scene.box.lengths)
    needed = sum(estimated_bytes(scene, box).values())
    # 600 particles in float64: 600 · 88 bytes of particle arrays at least.
    assert needed >= 600 * 88
    check_resources(scene, box, available=int(2 * needed))
    with pytest.raises(ResourceError, match="more than the .* GiB of memory available"):
        check_resources(scene, box, available=int(needed / 2))


def test_placement_that_cannot_finish_in_time_says_so(monkeypatch):
    scene = Scene.from_dict(lattice_scene(particles={"count": 60, "species": [{"name": "M"}]}))
    monkeypatch.setattr(placement, "PLACEMENT_SECONDS", 0.0)
    box = PeriodicBox(scene.box.lengths)
    with pytest.raises(ValueError, match=r"particles: placing 60 particles gave up after 0 s"):
        placement.initial_configuration(scene, box, jnp.float64, chain_blocks(scene))
