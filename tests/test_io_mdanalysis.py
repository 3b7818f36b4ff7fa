"""MDAnalysis (an optional test dependency) reads jaxdpd's H5MD files.

Values are checked against what was written, read with h5py directly (not through
jaxdpd's reader) and against the run's final state in memory.  MDAnalysis holds
positions in float32, so they are compared with the float32 rounding of the
float64 values written (exact equality: one correctly rounded conversion).
"""

import h5py
import numpy as np
import pytest
from io_runs import lees_edwards_edges, polymer_reference_run, reference_run

MDAnalysis = pytest.importorskip("MDAnalysis")

from jaxdpd.io.mdanalysis import mdanalysis_universe  # noqa: E402


def test_mdanalysis_reads_positions_sheared_box_time_and_reports_no_physical_units():
    reference = reference_run()
    scene, path = reference.scene, reference.path
    universe = MDAnalysis.Universe.empty(scene.n_particles, trajectory=True)
    universe.load_new(str(path), format="H5MD", convert_units=False)
    trajectory = universe.trajectory
    # Reduced units: the files carry no H5MD `unit` attributes, MDAnalysis says None.
    assert trajectory.units == {"time": None, "length": None, "velocity": None, "force": None}
    with h5py.File(path, "r") as handle:
        written = handle["particles/trajectory/position/value"][()]
        velocities = handle["particles/trajectory/velocity/value"][()]
        steps = handle["particles/trajectory/position/step"][()]
    assert trajectory.n_frames == len(written) == scene.run.steps // scene.output.trajectory_every
    for frame, timestep in enumerate(trajectory):
        np.testing.assert_array_equal(timestep.positions, written[frame].astype(np.float32))
        np.testing.assert_array_equal(timestep.velocities, velocities[frame].astype(np.float32))
        # The sheared box as a triclinic cell: |a|, |b|, |c| and the angles α(b, c),
        # β(a, c), γ(a, b) of a = (L_x, 0, 0), b = (Δ, L_y, 0), c = (0, 0, L_z).  float32
        # in MDAnalysis: rtol 1e-6 covers its rounding (the offset formula and the
        # run's step-by-step sum of Δ agree to 1e-12).
        (lx, _, _), (offset, ly, _), (_, _, lz) = lees_edwards_edges(scene, steps[frame])
        b = np.hypot(offset, ly)
        box = [lx, b, lz, 90.0, 90.0, np.degrees(np.arccos(offset / b))]
        np.testing.assert_allclose(timestep.dimensions, box, rtol=1e-6)
        assert timestep.data["step"] == steps[frame]
        assert timestep.time == pytest.approx(steps[frame] * scene.integrator.dt, rel=1e-15)
    final = np.asarray(reference.summary.state.positions).astype(np.float32)
    np.testing.assert_array_equal(trajectory[-1].positions, final)


def test_universe_helper_types_atoms_by_species_and_bonds_the_chains():
    reference = polymer_reference_run()
    scene, path = reference.scene, reference.path
    universe = mdanalysis_universe(path)
    counts = {s.name: s.count for s in scene.particles.species}
    types, numbers = np.unique(universe.atoms.types, return_counts=True)
    assert dict(zip(types.tolist(), numbers.tolist(), strict=True)) == counts
    # 48 dumbbell beads: 24 springs joining beads 2k and 2k + 1.
    assert len(universe.bonds) == counts["dumbbell"] // 2
    assert sorted(tuple(b.indices) for b in universe.bonds) == [
        (2 * k, 2 * k + 1) for k in range(counts["dumbbell"] // 2)
    ]
    assert len(universe.atoms.fragments) == counts["dumbbell"] // 2 + counts["solvent"]
    final = np.asarray(reference.summary.state.positions)
    np.testing.assert_array_equal(universe.trajectory[-1].positions, final)


def test_universe_helper_gives_each_frame_the_observables_at_its_step():
    """Frames every 20 steps, series every step: each frame's ts.data holds every
    series' value at the frame's step (plain MDAnalysis holds row k in frame k)."""
    reference = polymer_reference_run()
    with h5py.File(reference.path, "r") as handle:
        series = {}

        def collect(name, item):
            if isinstance(item, h5py.Group) and "step" in item and "value" in item:
                series[name] = dict(zip(item["step"][()].tolist(), item["value"][()], strict=True))

        handle["observables"].visititems(collect)
        frame_steps = handle["particles/trajectory/position/step"][()]
    assert {"temperature", "pressure_tensor", "dumbbell/bond_conformation"} <= set(series)
    universe = mdanalysis_universe(reference.path)
    for timestep, step in zip(universe.trajectory, frame_steps.tolist(), strict=True):
        assert timestep.data["step"] == step
        for name, by_step in series.items():
            np.testing.assert_array_equal(timestep.data[name], by_step[step], err_msg=name)
    # Random access reads the same values.
    np.testing.assert_array_equal(
        universe.trajectory[2].data["temperature"], series["temperature"][frame_steps[2]]
    )
