"""Open a jaxdpd H5MD file as an MDAnalysis Universe (MDAnalysis is optional).

MDAnalysis reads H5MD trajectories but infers a topology only from files whose data
carry physical units; jaxdpd's reduced units have none.  This builds the topology
from the file itself (species names as atom types and names, polymer springs as
bonds) and loads the trajectory with `convert_units=False`, so lengths stay in r_c
and times in τ (MDAnalysis reports their units as None).

MDAnalysis (2.11) fills a frame's `ts.data[name]` with row k of `/observables/<name>`
for the k-th frame, as if every series were sampled with the frames (MDAnalysis
issue 4561).  jaxdpd samples its series every step and writes frames every
output.trajectory_every steps, so that row belongs to another step;
`ObservablesAtFrameSteps` puts in each frame the value at the frame's own step.
"""

import numpy as np

from jaxdpd.io.layout import particle_group
from jaxdpd.io.reader import open_run_file, scene_of, time_series_names


class ObservablesAtFrameSteps:
    """An MDAnalysis on-the-fly transformation: `ts.data[name]` of every per-step
    series under /observables becomes its value at the frame's step (`ts.data["step"]`);
    a series that holds no value at that step is removed from `ts.data` rather than
    left with another step's value.

    The values at the frames' steps are read once, when it is made (frames × one
    sample of each series).

    Example (plain MDAnalysis, jaxdpd only for this):
        universe = MDAnalysis.Universe(path, convert_units=False, n_atoms=n)
        universe.trajectory.add_transformations(ObservablesAtFrameSteps(path))
    """

    def __init__(self, path):
        self.at_frames = {}  # name -> (row of each frame or -1, values at those rows)
        with open_run_file(path) as handle:
            frame_steps = handle[f"{particle_group(handle)}/position/step"][()]
            for name in time_series_names(handle):
                group = handle[f"observables/{name}"]
                steps = group["step"][()]
                rows = np.minimum(np.searchsorted(steps, frame_steps), max(len(steps) - 1, 0))
                found = steps[rows] == frame_steps if len(steps) else rows < 0
                # Increasing, distinct rows (the frames' steps increase): one h5py read.
                values = group["value"][rows[found]] if found.any() else None
                index = np.where(found, np.cumsum(found) - 1, -1)
                self.at_frames[name] = (index, values)

    def __call__(self, ts):
        for name, (index, values) in self.at_frames.items():
            row = index[ts.frame]
            if row >= 0:
                ts.data[name] = values[row]
            else:
                ts.data.pop(name, None)
        return ts


def mdanalysis_universe(path):
    """An MDAnalysis Universe of the frames stored in `path`.

    Args:
        path: an H5MD file written by jaxdpd with frames (output.trajectory_every).
    Returns:
        MDAnalysis.Universe: atoms typed and named by species, bonds from
        /connectivity/bonds, the H5MD trajectory (positions, velocities, box, time),
        and in each frame's `ts.data` the observables at the frame's step
        (`ObservablesAtFrameSteps`).
    Raises:
        ImportError: MDAnalysis is not installed.
        RunFileError: the file cannot be read.
    """
    import MDAnalysis

    with open_run_file(path) as handle:
        scene = scene_of(handle)
        species = handle[f"{particle_group(handle)}/species"][()]
        bonds = handle["connectivity/bonds"][()] if "connectivity/bonds" in handle else None
    names = np.asarray(scene.species_names, dtype=object)[species]
    universe = MDAnalysis.Universe.empty(len(names), trajectory=True)
    universe.add_TopologyAttr("type", names)
    universe.add_TopologyAttr("name", names)
    if bonds is not None and len(bonds):
        universe.add_TopologyAttr("bonds", [tuple(pair) for pair in bonds.tolist()])
    universe.load_new(str(path), format="H5MD", convert_units=False)
    universe.trajectory.add_transformations(ObservablesAtFrameSteps(path))
    return universe
