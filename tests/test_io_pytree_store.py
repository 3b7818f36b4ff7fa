"""Checkpoints store any pytree leaf for leaf, bit for bit, without knowing its fields.

A state with fields nobody had when the I/O code was written (a nested solvent
state, a box state, dictionaries, tuples, None, static fields of every kind) goes
through `write_tree` / `read_tree` unchanged; mismatches and damage are refused
with messages naming the leaf.
"""

import enum
from typing import NamedTuple

import h5py
import jax.numpy as jnp
import numpy as np
import pytest
from conftest import make_scene
from io_runs import assert_same_leaves, reference_run

from jaxdpd import pytree
from jaxdpd.engine.build import build
from jaxdpd.io import (
    RunFileError,
    read_checkpoint,
    read_scene,
    read_state,
    read_tree,
    write_tree,
)
from jaxdpd.run.restore import restore


class Lattice(enum.Enum):
    D3Q19 = 19


def relax(x):
    return x


def other_relax(x):
    return x


@pytree.dataclass
class FluidState:
    """A stand-in for a lattice-Boltzmann solvent state added later by someone else."""

    populations: jnp.ndarray
    moments: dict
    lattice: Lattice = pytree.static_field(default=Lattice.D3Q19)
    grid: tuple = pytree.static_field(default=(4, 4, 4))
    collide: object = pytree.static_field(default=relax)


class BoxState(NamedTuple):
    offset: jnp.ndarray
    strain: jnp.ndarray


@pytree.dataclass
class FutureState:
    positions: jnp.ndarray
    solvent_state: FluidState
    box_state: BoxState
    history: tuple
    nothing: object = None


def future_state(n: int = 5, cells: int = 4) -> FutureState:
    bits = np.array([0.0, -0.0, np.nan, np.inf, 1e-310], np.float64)  # -0, NaN, subnormal
    return FutureState(
        positions=jnp.asarray(np.linspace(0, 1, 3 * n).reshape(n, 3), jnp.float32),
        solvent_state=FluidState(
            populations=jnp.arange(19 * cells, dtype=jnp.float64).reshape(19, cells) / 7,
            moments={"density": jnp.asarray(bits), "flag": jnp.asarray(True)},
            grid=(cells, cells, cells),
        ),
        box_state=BoxState(jnp.asarray(0.25, jnp.float64), jnp.asarray(7, jnp.uint32)),
        history=(jnp.zeros((0, 3), jnp.int32), jnp.asarray(-3, jnp.int64)),
    )


@pytest.fixture
def store(tmp_path):
    with h5py.File(tmp_path / "tree.h5", "w") as handle:
        yield handle.create_group("state")


def test_a_state_with_new_fields_round_trips_bit_for_bit(store):
    state = future_state(n=5, cells=6)
    write_tree(store, state)
    restored = read_tree(store, future_state(n=2, cells=4))  # template: other shapes
    assert_same_leaves(restored, state)
    assert restored.solvent_state.grid == (6, 6, 6)  # JSON statics come from the file
    assert restored.solvent_state.lattice is Lattice.D3Q19
    assert restored.solvent_state.collide is relax  # functions from the template
    assert store["solvent_state/moments/density"].dtype == np.float64


def test_rewriting_a_tree_overwrites_in_place_and_removes_stale_leaves(store):
    write_tree(store, future_state(n=5))
    data_offset = store["positions"].id.get_offset()
    write_tree(store, future_state(n=5).set(positions=jnp.ones((5, 3), jnp.float32)))
    assert store["positions"].id.get_offset() == data_offset  # same storage, new values
    np.testing.assert_array_equal(store["positions"][()], np.ones((5, 3)))
    write_tree(store, {"only": jnp.zeros(2)})
    assert sorted(store) == ["only"]


@pytest.mark.parametrize(
    "template, message",
    [
        (lambda s: s.set(nothing=jnp.zeros(1)), r"nothing is missing"),
        (lambda s: s.set(box_state=BoxState(s.box_state.offset, None)), r"box_state/strain"),
        (lambda s: s.set(positions=s.positions.astype(jnp.float64)), r"float32.*float64"),
        (
            lambda s: s.set(solvent_state=s.solvent_state.set(collide=other_relax)),
            r"collide.*relax.*other_relax",
        ),
        (lambda s: s.set(solvent_state=s.solvent_state.set(grid=None)), r"static field 'solvent"),
    ],
    ids=["missing leaf", "extra leaf", "dtype", "static function", "static kind"],
)
def test_a_template_that_does_not_fit_is_refused_naming_the_part(store, template, message):
    write_tree(store, future_state())
    with pytest.raises(RunFileError, match=message):
        read_tree(store, template(future_state()))


def test_a_damaged_leaf_fails_its_checksum(tmp_path):
    path = tmp_path / "tree.h5"
    with h5py.File(path, "w") as handle:
        write_tree(handle.create_group("state"), future_state())
        offset = handle["state/solvent_state/populations"].id.get_offset()
    with open(path, "r+b") as raw:  # flip one byte of the stored values
        raw.seek(offset + 11)
        byte = raw.read(1)
        raw.seek(offset + 11)
        raw.write(bytes([byte[0] ^ 0x10]))
    with h5py.File(path, "r") as handle:
        with pytest.raises(RunFileError, match="populations fails its checksum"):
            read_tree(handle["state"], future_state())


def test_a_checkpointed_simstate_restores_through_the_scenes_build():
    """The reference run's end-of-run checkpoint, loaded back by read_state (template
    from build(scene).init_fn()), equals the final state the run returned, as does
    jaxdpd.run.restore's; the raw reader gives the same leaves by path without a scene."""
    reference = reference_run()
    template = build(read_scene(reference.path)).init_fn()
    state = read_state(reference.path, template)
    assert_same_leaves(state, reference.summary.state)
    _, state = restore(reference.path)
    assert_same_leaves(state, reference.summary.state)
    raw = read_checkpoint(reference.path)
    np.testing.assert_array_equal(raw["pair_list/i"], reference.summary.state.pair_list.i)
    assert raw["step"] == reference.scene.run.steps and raw["phase"] == "production"


def test_a_jax_md_neighbour_list_state_restores_its_statics(store):
    """jax-md's NeighborList has static capacities (restored from the file), an enum
    and functions (taken from the template, a state of another allocation)."""
    # The scene of test_dpd_invariants' format test: built once per session.
    scene = make_scene(
        neighbors={"method": "jax_md", "format": "dense", "skin": 0.3}, particles={"count": 700}
    )
    simulation = build(scene)
    state = simulation.init_fn()
    lists = state.pair_list.backend
    stored = state.set(pair_list=state.pair_list.set(backend=lists.set(max_occupancy=99)))
    write_tree(store, stored)
    template = simulation.init_fn()
    restored = read_tree(store, template)
    assert_same_leaves(restored, stored)
    assert restored.pair_list.backend.max_occupancy == 99
    assert restored.pair_list.backend.update_fn is template.pair_list.backend.update_fn
    assert restored.pair_list.backend.format == lists.format
