"""jaxdpd's H5MD files as other readers see them: the units of every dataset, pyh5md
(the H5MD authors' reader) and a plain MDAnalysis.Universe without jaxdpd's bridge,
as docs/file_formats.md describes them (its quoted messages and snippet are run here).

The dimensions below are written from what each quantity is (its definition in the
module docstrings and the thesis), not from the code's unit table: L length (r_c),
T time (τ), M mass (m), E energy (k_BT).  Each file label is parsed into these
dimensions and compared.
"""

import re
import shutil
from pathlib import Path

import h5py
import numpy as np
import pytest
from io_runs import polymer_reference_run

from jaxdpd.io import read_trajectory
from jaxdpd.io.h5md import H5MDWriter
from jaxdpd.io.reader import read_unwrapped_positions

L, T, M, E = "L", "T", "M", "E"
# element (species prefix dropped) -> {dimension: exponent}
DIMENSIONS = {
    "position": {L: 1},
    "velocity": {L: 1, T: -1},  # peculiar velocity
    "image": {},  # counts of crossed faces
    "mass": {M: 1},
    "box/edges": {L: 1},
    "time": {T: 1},
    "lag_time": {T: 1},
    "temperature": {E: 1},  # k_BT
    "pressure": {E: 1, L: -3},
    "pressure_tensor": {E: 1, L: -3},
    "pressure_tensor_part": {E: 1, L: -3},
    "bond_length_sq": {L: 2},  # ⟨Q²⟩
    "bond_conformation": {L: 2},  # ⟨Q Q⟩
    "fractional_extension": {},  # ⟨|R_e|⟩ / L_c
    "fractional_extension_sq": {},  # ⟨R_e²⟩ / L_c²
    "gyration_radius_sq": {L: 2},
    "spring_pair_pressure": {E: 1, L: -3},  # a pressure tensor
    "g1": {L: 2},  # bead mean-square displacement
    "g2": {L: 2},  # bead MSD relative to the chain centre
    "g3": {L: 2},  # centre-of-mass MSD
    "end_to_end_acf": {L: 2},  # ⟨R_e(t0) · R_e(t0 + t)⟩
    "positional_acf": {L: 2},  # ⟨u_i(t0) · u_i(t0 + t)⟩
    "rdf/r": {L: 1},
    "rdf/g": {},  # g(r), a density ratio
}
# Label symbols of the reduced units (/parameters:units: r_c = m = k_BT = 1, τ).
SYMBOLS = {"r_c": L, "τ": T, "m": M, "k_BT": E}
UNLABELLED = ("step", "species", "connectivity/bonds")


def dimensions_of(label: str) -> dict:
    """{dimension: exponent} of a label such as "k_BT/r_c^3", "r_c^-3", "1"."""
    result = {}
    numerator, *denominators = label.split("/")
    for sign, part in [(1, numerator)] + [(-1, d) for d in denominators]:
        for factor in part.split():
            if factor == "1":
                continue
            match = re.fullmatch(r"(r_c|τ|m|k_BT)(?:\^(-?\d+))?", factor)
            assert match, f"unparsable unit {label!r}"
            dimension = SYMBOLS[match.group(1)]
            result[dimension] = result.get(dimension, 0) + sign * int(match.group(2) or 1)
    return {k: v for k, v in result.items() if v}


def element_name(path: str, species: tuple) -> str:
    """The DIMENSIONS key of a dataset path."""
    parts = path.split("/")
    if parts[-1] in ("time", "lag_time"):
        return parts[-1]
    if parts[-1] in ("value", "per_element"):
        parts = parts[:-1]
    parts = [p for p in parts[1:] if p not in species and p != "trajectory"]
    name = "/".join(parts)
    return "pressure_tensor_part" if name.startswith("pressure_tensor_part/") else name


def test_every_dataset_carries_the_reduced_unit_of_its_dimensions():
    reference = polymer_reference_run()
    species = reference.scene.species_names
    checked = []
    with h5py.File(reference.path, "r") as handle:

        def visit(path, item):
            if not isinstance(item, h5py.Dataset) or path.endswith(UNLABELLED):
                return
            name = element_name(path, species)
            assert name in DIMENSIONS, f"{path}: not in the test's table"
            label = item.attrs.get("reduced_unit")
            assert label is not None, f"{path}: no reduced_unit"
            assert dimensions_of(label) == DIMENSIONS[name], f"{path}: {label!r}"
            checked.append(name)

        handle.visititems(visit)
    # The run writes every element of the table (a test that checks nothing fails).
    assert set(checked) == set(DIMENSIONS)


def test_pyh5md_reads_frames_box_and_masses():
    pyh5md = pytest.importorskip("pyh5md")
    reference = polymer_reference_run()
    scene = reference.scene
    with pyh5md.File(str(reference.path), "r") as handle:
        assert list(handle["h5md"].attrs["version"]) == [1, 1]
        particles = handle.particles_group("trajectory")
        position = pyh5md.element(particles, "position")
        assert position.element_type == "TimeElement"
        edges = pyh5md.element(particles["box"], "edges")
        mass = pyh5md.element(particles, "mass")
        assert mass.element_type == "FixedElement"
        np.testing.assert_array_equal(mass.value[()], np.ones(scene.n_particles))
        np.testing.assert_array_equal(position.step[()], edges.step[()])
        final = np.asarray(reference.summary.state.positions)
        np.testing.assert_array_equal(position.value[-1], final)
        np.testing.assert_allclose(edges.value[-1], scene.box.lengths, rtol=1e-15)


def documented_block(marker: str) -> str:
    """The fenced block after `<!-- test: marker -->` in docs/file_formats.md."""
    page = (Path(__file__).resolve().parent.parent / "docs" / "file_formats.md").read_text()
    match = re.search(rf"<!-- test: {marker} -->\n```\w+\n(.*?)```", page, re.S)
    assert match, f"docs/file_formats.md: no block marked {marker!r}"
    return match.group(1)


def test_mdanalysis_opens_the_file_without_a_topology_or_jaxdpd():
    """MDAnalysis 2.11 finds the particle count in a group named "trajectory" (its
    H5MDReader.parse_n_atoms) and refuses data without SI `unit` attributes unless
    told `convert_units=False` (as for LAMMPS's H5MD files, MDAnalysis issue 4722);
    with that keyword its minimal-topology parser passes it on to parse_n_atoms,
    which does not take it, so the count is then given (n_atoms).  No jaxdpd code,
    no topology file.  The calls that fail, fail with the messages the docs quote."""
    MDAnalysis = pytest.importorskip("MDAnalysis")
    reference = polymer_reference_run()
    path, n = str(reference.path), reference.scene.n_particles
    assert path.endswith(".h5md")  # MDAnalysis picks its reader by the extension
    lines = documented_block("mdanalysis messages").splitlines()
    calls = [line.removeprefix(">>> ") for line in lines if line.startswith(">>> ")]
    messages = [line for line in lines if not line.startswith(">>> ")]
    assert len(calls) == len(messages) == 2
    for call, message in zip(calls, messages, strict=True):
        with pytest.raises(Exception) as raised:
            eval(call.replace('"run.h5md"', "path"), {"MDAnalysis": MDAnalysis, "path": path})
        assert f"{raised.type.__name__}: {raised.value}" == message, call
    universe = MDAnalysis.Universe(path, convert_units=False, n_atoms=n)
    frames = read_trajectory(path)
    assert universe.trajectory.n_frames == len(frames.step)
    for timestep, expected in zip(universe.trajectory, frames.value, strict=True):
        np.testing.assert_array_equal(timestep.positions, expected.astype(np.float32))


def test_mdanalysis_observables_at_the_frames_steps_as_documented():
    """Plain MDAnalysis puts row k of each series in frame k (the docs say so: the
    reference run's frames are every 20 steps, its series every step); the docs'
    snippet reads the temperature at each frame's step through the series' `step`."""
    MDAnalysis = pytest.importorskip("MDAnalysis")
    reference = polymer_reference_run()
    path, n = str(reference.path), reference.scene.n_particles
    with h5py.File(path, "r") as handle:
        steps = handle["observables/temperature/step"][()]
        values = handle["observables/temperature/value"][()]
        frame_steps = handle["particles/trajectory/position/step"][()]
    by_step = dict(zip(steps.tolist(), values, strict=True))
    assert np.all(np.diff(frame_steps) > 1)  # frames and series are sampled apart
    universe = MDAnalysis.Universe(path, convert_units=False, n_atoms=n)
    for k, timestep in enumerate(universe.trajectory):
        assert timestep.data["step"] == frame_steps[k]
        assert timestep.data["temperature"] == values[k]  # by index, as documented
    namespace = {"path": path, "n_atoms": n}
    exec(documented_block("mdanalysis observables"), namespace)
    expected = [by_step[step] for step in frame_steps.tolist()]
    np.testing.assert_array_equal(namespace["temperature_at_frames"], expected)
    assert not np.array_equal(expected, values[: len(frame_steps)])


def test_author_option_and_files_written_before_the_group_rename(tmp_path):
    reference = polymer_reference_run()
    scene = reference.scene.replace(output={"author": "A. N. Author"})
    with H5MDWriter.create(tmp_path / "header.h5md", scene) as writer:
        assert writer.file["h5md/author"].attrs["name"] == "A. N. Author"
    # A file whose particle group is called "all" (jaxdpd before 0.2) reads alike.
    legacy = tmp_path / "legacy.h5"
    shutil.copyfile(reference.path, legacy)
    with h5py.File(legacy, "r+") as handle:
        handle.move("particles/trajectory", "particles/all")
    np.testing.assert_array_equal(
        read_trajectory(legacy).value, read_trajectory(reference.path).value
    )
    np.testing.assert_array_equal(
        read_unwrapped_positions(legacy).value, read_unwrapped_positions(reference.path).value
    )
