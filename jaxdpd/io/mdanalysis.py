"""Open a jaxdpd H5MD file as an MDAnalysis Universe (MDAnalysis is optional).

MDAnalysis reads H5MD trajectories but infers a topology only from files whose data
carry physical units; jaxdpd's reduced units have none.  This builds the topology
from the file itself (species names as atom types and names, polymer springs as
bonds) and loads the trajectory with `convert_units=False`, so lengths stay in r_c
and times in τ (MDAnalysis reports their units as None).
"""

import numpy as np

from jaxdpd.io.layout import particle_group
from jaxdpd.io.reader import open_run_file, scene_of


def mdanalysis_universe(path):
    """An MDAnalysis Universe of the frames stored in `path`.

    Args:
        path: an H5MD file written by jaxdpd with frames (output.trajectory_every).
    Returns:
        MDAnalysis.Universe: atoms typed and named by species, bonds from
        /connectivity/bonds, the H5MD trajectory (positions, velocities, box, time).
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
    return universe
