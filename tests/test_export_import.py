"""`jaxdpd export` to GSD, extended XYZ and LAMMPS data, and runs started from them.

The exported files are read back with the gsd package itself (HOOMD's box and
position conventions as its documentation states them: box [L_x, L_y, L_z, xy, xz,
yz] with a2 = (xy L_y, L_y, 0), positions in the cell centred on the origin;
gsd.readthedocs.io, "HOOMD schema") and by parsing the text formats' box lines, and
compared with the H5MD file read by h5py.  A Lees–Edwards frame's lattice is
a1 = (L_x, 0, 0), a2 = (Δ, L_y, 0), a3 = (0, 0, L_z) with Δ = γ̇ L_y t folded into
[−L_x/2, L_x/2) (thesis §3.3; io_runs.lees_edwards_edges), so the exported tilt is
xy = Δ/L_y in GSD and xy = Δ in LAMMPS.  Positions are compared unwrapped
(position + image counters · lattice), which no choice of primary cell changes.
"""

import h5py
import numpy as np
import pytest
from io_runs import lees_edwards_edges, polymer_reference_run, reference_run

from jaxdpd.geometry.boxes import make_box
from jaxdpd.geometry.chain_topology import chain_blocks
from jaxdpd.geometry.placement import initial_configuration
from jaxdpd.io.formats import FILE_FORMATS
from jaxdpd.io.formats.configuration import Configuration
from jaxdpd.io.h5md import H5MDWriter, box_edges
from jaxdpd.io.initial import read_initial
from jaxdpd.run.cli import main
from jaxdpd.run.runner import prepare
from jaxdpd.scene import Flow
from jaxdpd.validation import SceneError

gsd_hoomd = pytest.importorskip("gsd.hoomd")
EPS32 = np.finfo(np.float32).eps


def stored_frames(path):
    """(steps, positions, velocities, image, edges) of every frame, read with h5py."""
    with h5py.File(path, "r") as handle:
        particles = handle["particles/trajectory"]
        return (
            particles["position/step"][()],
            particles["position/value"][()].astype(np.float64),
            particles["velocity/value"][()].astype(np.float64),
            particles["image/value"][()],
            particles["box/edges/value"][()],
        )


def lattice_of(edges):
    return np.diag(edges) if edges.ndim == 1 else edges


def unwrapped(positions, image, lattice):
    return positions + image @ lattice


def hoomd_lattice(box):
    lx, ly, lz, xy, xz, yz = np.asarray(box, np.float64)
    return np.array([[lx, 0, 0], [xy * ly, ly, 0], [xz * lz, yz * lz, lz]])


def export(run_file, output, fmt, *extra):
    assert main(["export", str(run_file), "--format", fmt, "-o", str(output), *extra]) == 0


def test_gsd_export_carries_the_sheared_tilt_positions_and_velocities(tmp_path):
    reference = reference_run()
    scene = reference.scene
    output = tmp_path / "sheared.gsd"
    export(reference.path, output, "gsd", "--frames", "::10")
    steps, positions, velocities, image, edges = stored_frames(reference.path)
    with gsd_hoomd.open(str(output), mode="r") as trajectory:
        frames = list(trajectory)
    assert len(frames) == len(range(0, len(steps), 10))
    for k, frame in zip(range(0, len(steps), 10), frames, strict=True):
        assert frame.configuration.step == steps[k]
        (lx, _, _), (offset, ly, _), (_, _, lz) = lees_edwards_edges(scene, steps[k])
        # float32 in GSD: one rounding of each box number.
        np.testing.assert_allclose(
            frame.configuration.box, [lx, ly, lz, offset / ly, 0, 0], rtol=2 * EPS32, atol=EPS32
        )
        lattice = hoomd_lattice(frame.configuration.box)
        fractions = frame.particles.position @ np.linalg.inv(lattice)
        assert np.all((fractions >= -0.5 - 1e-6) & (fractions < 0.5 + 1e-6))  # centred cell
        ours = unwrapped(positions[k], image[k], edges[k])
        theirs = unwrapped(frame.particles.position, frame.particles.image, lattice)
        theirs += lattice.sum(axis=0) / 2
        # Bound: float32 rounding of the position and of the box numbers it is built of.
        bound = 4 * EPS32 * (np.abs(ours) + np.abs(frame.particles.image) @ np.abs(lattice) + lx)
        assert np.all(np.abs(theirs - ours) <= bound)
        np.testing.assert_allclose(frame.particles.velocity, velocities[k], rtol=EPS32, atol=EPS32)


def test_gsd_export_carries_species_masses_and_bonds_and_reads_back(tmp_path):
    reference = polymer_reference_run()
    scene = reference.scene
    output = tmp_path / "dumbbells.gsd"
    export(reference.path, output, "gsd")
    steps, positions, _, image, edges = stored_frames(reference.path)
    with gsd_hoomd.open(str(output), mode="r") as trajectory:
        last = trajectory[-1]
    assert last.particles.types == ["dumbbell", "solvent"]
    np.testing.assert_array_equal(last.particles.typeid, [0] * 48 + [1] * 144)
    np.testing.assert_array_equal(last.particles.mass, np.ones(192))
    # 24 dumbbells: beads 2k and 2k + 1 (species after species, chains bead after bead).
    assert last.bonds.N == 24 and last.bonds.types == ["dumbbell"]
    np.testing.assert_array_equal(last.bonds.group, [[2 * k, 2 * k + 1] for k in range(24)])
    back = FILE_FORMATS.get("gsd").read(output)
    assert back.step == steps[-1] and back.species_names == scene.species_names
    np.testing.assert_array_equal(back.bonds, [[2 * k, 2 * k + 1] for k in range(24)])
    np.testing.assert_allclose(back.lattice, lattice_of(edges[-1]), rtol=EPS32)
    np.testing.assert_allclose(
        back.unwrapped(), unwrapped(positions[-1], image[-1], lattice_of(edges[-1])), atol=1e-5
    )


def test_lammps_data_and_xyz_carry_the_tilt_exactly(tmp_path):
    reference = reference_run()
    scene = reference.scene
    steps, positions, velocities, image, edges = stored_frames(reference.path)
    k = 10  # step 220: Δ = γ̇ L_y t = 22 folded to 2 (L_x = 5)
    lattice = lees_edwards_edges(scene, steps[k])
    assert abs(lattice[1, 0]) > 1
    data, xyz = tmp_path / "last.data", tmp_path / "sheared.xyz"
    export(reference.path, data, "lammps-data", "--atom-style", "full", "--frames", str(k))
    export(reference.path, xyz, "xyz", "--frames", f"{k}:{k + 1}")
    text = data.read_text()
    tilt = next(line for line in text.splitlines() if line.endswith("xy xz yz"))
    # LAMMPS tilts are lengths: xy = Δ (docs.lammps.org/Howto_triclinic.html); the
    # run sums Δ step by step, the formula at once: 1e-12 apart.
    np.testing.assert_allclose(
        [float(v) for v in tilt.split()[:3]], [lattice[1, 0], 0, 0], atol=1e-12
    )
    assert "Atoms  # full" in text
    header = xyz.read_text().splitlines()[1]
    lattice_text = header.split('Lattice="')[1].split('"')[0]
    np.testing.assert_allclose(np.array(lattice_text.split(), float), lattice.ravel(), atol=1e-12)
    ours = unwrapped(positions[k], image[k], edges[k])
    back = FILE_FORMATS.get("lammps-data").read(data)
    np.testing.assert_array_equal(back.lattice, edges[k])  # 17 digits: exact
    np.testing.assert_allclose(back.unwrapped(), ours, rtol=0, atol=1e-12)
    np.testing.assert_array_equal(back.velocities, velocities[k])
    from_xyz = FILE_FORMATS.get("xyz").read(xyz)
    np.testing.assert_array_equal(from_xyz.lattice, edges[k])
    # No image counters in XYZ: equal up to a lattice vector.
    fractions = (from_xyz.positions - ours) @ np.linalg.inv(edges[k])
    np.testing.assert_allclose(fractions, np.round(fractions), atol=1e-12)


def test_a_run_started_from_an_exported_file_starts_from_its_positions(tmp_path):
    reference = polymer_reference_run()
    steps, positions, velocities, image, edges = stored_frames(reference.path)
    lattice = lattice_of(edges[-1])
    last = unwrapped(positions[-1], image[-1], lattice)
    gsd_file, data_file, xyz_file = tmp_path / "a.gsd", tmp_path / "a.data", tmp_path / "a.xyz"
    export(reference.path, gsd_file, "gsd")
    export(reference.path, data_file, "lammps-data")
    export(reference.path, xyz_file, "xyz")
    scene = reference.scene.replace(initial={"file": str(gsd_file)})
    run = prepare(scene, None, progress=False)  # as `jaxdpd run` starts it
    state = run.state
    started = unwrapped(np.asarray(state.positions, np.float64), np.asarray(state.image), lattice)
    np.testing.assert_allclose(started, last, atol=1e-5)  # GSD: float32 positions
    np.testing.assert_array_equal(np.asarray(state.velocities), velocities[-1])
    # LAMMPS data: 17 digits, so the float32 positions come back exactly.
    given = read_initial(reference.scene.replace(initial={"file": str(data_file)}))
    state = run.simulation.init_fn(**given)
    np.testing.assert_array_equal(np.asarray(state.positions), positions[-1])
    np.testing.assert_array_equal(np.asarray(state.image), image[-1])
    np.testing.assert_array_equal(np.asarray(state.velocities), velocities[-1])
    # XYZ: no image counters; the dumbbells are made whole by minimum image.
    given = read_initial(reference.scene.replace(initial={"file": str(xyz_file)}))
    springs = given["positions"][1:48:2] - given["positions"][0:48:2]
    np.testing.assert_allclose(springs, last[1:48:2] - last[0:48:2], atol=1e-6)


DUMBBELL = {"name": "dumbbell", "count": 48}


@pytest.mark.parametrize(
    "change, message",
    [
        (
            {
                "box": {"kind": "periodic"},
                "particles": {
                    "count": 195,
                    "density": 3.0,
                    "species": [DUMBBELL, {"name": "solvent", "count": 147}],
                },
            },
            "holds 192 particles, the scene 195",
        ),
        (
            {"particles": {"count": 192, "species": [{"name": "solvent", "count": 144}, DUMBBELL]}},
            "particle 0 is of species 'dumbbell', the scene has 'solvent'",
        ),
        (
            {
                "polymers": [
                    {
                        "species": "dumbbell",
                        "beads": 4,
                        "bond": {"law": "hookean", "spring_constant": 3.0},
                    }
                ]
            },
            "its 24 bonds are not the scene's 36 springs",
        ),
        (
            {
                "box": {"lengths": [4.0, 4.0, 12.0]},
                "particles": {
                    "count": 192,
                    "species": [DUMBBELL, {"name": "solvent", "count": 144}],
                },
            },
            "its box edges .* are not box.lengths",
        ),
    ],
    ids=["count", "species", "bonds", "box"],
)
def test_a_file_that_does_not_fit_the_scene_is_refused_naming_initial_file(
    tmp_path, change, message
):
    reference = polymer_reference_run()
    output = tmp_path / "a.gsd"
    export(reference.path, output, "gsd")
    data = reference.scene.to_dict()
    data.update(change, initial={"file": str(output)})
    scene = type(reference.scene).from_dict(data)
    with pytest.raises(SceneError, match=message) as raised:
        read_initial(scene)
    assert raised.value.field == "initial.file"


def test_initial_section_errors_name_their_field():
    data = polymer_reference_run().scene.to_dict()
    with pytest.raises(SceneError, match="does not follow from its extension") as raised:
        type(polymer_reference_run().scene).from_dict({**data, "initial": {"file": "x.pdb"}})
    assert raised.value.field == "initial.format"
    with pytest.raises(SceneError, match="cannot read it as gsd") as raised:
        read_initial(polymer_reference_run().scene.replace(initial={"file": "missing.gsd"}))
    assert raised.value.field == "initial.file"


def test_kraynik_reinelt_cells_go_to_xyz_and_are_refused_by_gsd_and_lammps(tmp_path):
    """A Kraynik–Reinelt cell (thesis §3.4, case 1 at the start: tilted in x–z) is no
    restricted triclinic cell; XYZ stores its lattice vectors as they are."""
    box = make_box("kraynik_reinelt", (7.0, 5.0, 7.0), Flow("planar_elongation", 0, None, 0.2))
    lattice = box_edges(box.bind(box.initial_state(np.float64)))
    assert lattice[0, 2] != 0  # a1 leaves the x–y plane
    rng = np.random.default_rng(1)
    positions = rng.uniform(size=(20, 3)) @ lattice
    configuration = Configuration(positions, lattice, np.zeros(20, int), ("a",))
    for name, suffix in (("gsd", ".gsd"), ("lammps-data", ".data")):
        with pytest.raises(ValueError, match="export it as extended XYZ"):
            FILE_FORMATS.get(name).write(tmp_path / f"kr{suffix}", [configuration])
    FILE_FORMATS.get("xyz").write(tmp_path / "kr.xyz", [configuration])
    back = FILE_FORMATS.get("xyz").read(tmp_path / "kr.xyz")
    np.testing.assert_array_equal(back.lattice, lattice)
    fractions = (back.positions - positions) @ np.linalg.inv(lattice)
    np.testing.assert_allclose(fractions, np.round(fractions), atol=1e-12)


def test_bad_positions_and_a_run_without_frames_are_refused_clearly(tmp_path, capsys):
    scene = polymer_reference_run().scene
    box = make_box(scene.box.kind, scene.box.lengths, scene.flow)
    with pytest.raises(ValueError, match=r"init_fn: positions must be a finite \(N, 3\) array"):
        initial_configuration(scene, box, np.float32, chain_blocks(scene), np.zeros((5, 3)))
    empty = tmp_path / "header.h5md"
    H5MDWriter.create(empty, scene).close()  # no frames written
    assert main(["export", str(empty), "--format", "xyz"]) == 2
    assert "holds no frames to export" in capsys.readouterr().err
    # A misspelt format names the option, not the scene's initial.format.
    assert main(["export", str(empty), "--format", "lamps-data"]) == 2
    assert "invalid input: --format: 'lamps-data'" in capsys.readouterr().err
