"""Contract tests of every registered observable (jaxdpd.observables.OBSERVABLES).

Each observable provides a small scene that records it (`Observable.example_scene`).
The examples are merged into one float32 scene (every observable listed, every
section and setting any of them adds), which the file-writing runner runs into a
temporary H5MD file once for the whole module: one compile serves every observable.
For every observable:

- its per-step series have one row per recorded step and stay float32 in the file;
- reading them back (jaxdpd.io.read_observable) gives the values the runner held in
  memory, bit for bit (H5MD round trip);
- each value dataset carries its `reduced_unit` attribute;
- an observable without per-step series writes chunk-end results under /averages.

A series belongs to the observable whose `units` name it (a leaf name, or a group
prefix ending in "/"), else to the observable whose name is its first path part.
"""

import h5py
import numpy as np
import pytest

from jaxdpd.io import read_observable
from jaxdpd.io.reader import time_series_names
from jaxdpd.observables import OBSERVABLES
from jaxdpd.observables.component import Observable
from jaxdpd.run.runner import simulate
from jaxdpd.scene import Scene

NAMES = OBSERVABLES.names()


def merged_example(precision: str) -> dict:
    """Every observable's example scene merged: observables and [output] settings
    united, other sections taken from the example that has them."""
    merged = None
    for component in OBSERVABLES:
        data = component.example_scene(precision)
        if merged is None:
            merged = data
            continue
        output = data.get("output", {})
        listed = merged["output"]["observables"]
        listed += [name for name in output.get("observables", []) if name not in listed]
        merged["output"].update({k: v for k, v in output.items() if k != "observables"})
        merged.update({k: v for k, v in data.items() if k != "output"})
    return merged


def owner(name: str):
    """The observable a stored series belongs to (module docstring), or None."""
    leaf = name.rsplit("/", 1)[-1]
    for component in OBSERVABLES:
        for key in component.units:
            if key == leaf or (key.endswith("/") and key in name):
                return component.name
    first = name.split("/", 1)[0]
    return first if first in OBSERVABLES else None


@pytest.fixture(scope="module")
def recorded(tmp_path_factory):
    scene = Scene.from_dict(merged_example("float32"))
    assert set(scene.output.observables) == set(NAMES)
    path = tmp_path_factory.mktemp("observables") / "run.h5"
    summary = simulate(scene, path, progress=False, keep_series=True)
    with h5py.File(path, "r") as handle:
        names = time_series_names(handle)
        averages = []
        if "averages" in handle:
            handle["averages"].visit(averages.append)
    return scene, path, summary, names, averages


def owned(recorded, name: str) -> list:
    return [series for series in recorded[3] if owner(series) == name]


@pytest.mark.parametrize("name", NAMES)
def test_series_round_trip(recorded, name):
    """Rows = recorded steps, float32 kept, file values == the runner's in memory."""
    scene, path, summary, _, averages = recorded
    component = OBSERVABLES.get(name)
    series_names = owned(recorded, name)
    if not series_names:
        # Chunk-end results only (g(r), correlators): written under /averages.
        overrides = type(component).chunk_accumulator is not Observable.chunk_accumulator
        assert component.accumulates or overrides, name
        assert averages, f"{name}: no per-step series and nothing under /averages"
        return
    steps = scene.run.steps
    for series in series_names:
        stored = read_observable(path, series)
        assert stored.value.dtype == np.float32, (series, stored.value.dtype)
        assert stored.value.shape[0] == stored.step.shape[0] == steps, series
        np.testing.assert_array_equal(stored.step, np.arange(1, steps + 1))
        memory = summary.series[series]
        assert memory.shape == stored.value.shape, series
        np.testing.assert_array_equal(stored.value, memory, err_msg=series)


@pytest.mark.parametrize("name", NAMES)
def test_series_have_units(recorded, name):
    """Every per-step value dataset of the observable has a `reduced_unit` attribute."""
    path = recorded[1]
    with h5py.File(path, "r") as handle:
        missing = [
            series
            for series in owned(recorded, name)
            if "reduced_unit" not in handle[f"observables/{series}/value"].attrs
        ]
    assert not missing, missing


def test_every_stored_series_has_an_owner(recorded):
    """No per-step series in the file is left without an observable it belongs to,
    or at least a unit of the file layout (e.g. conformation's spring-pair pressure)."""
    path, names = recorded[1], recorded[3]
    with h5py.File(path, "r") as handle:
        orphans = [
            series
            for series in names
            if owner(series) is None
            and "reduced_unit" not in handle[f"observables/{series}/value"].attrs
        ]
    assert names and not orphans, orphans
