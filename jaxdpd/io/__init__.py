"""Output files: H5MD trajectories and observables, checkpoints, and reading them back.

Reading imports no part of the engine and compiles nothing; restoring a checkpointed
state into a built simulation is jaxdpd.run.restore.

H5MDWriter                          jaxdpd.io.h5md (layout in its docstring)
write_tree / read_tree              any pytree to/from an HDF5 group, bit for bit
load, read_scene, read_state,       jaxdpd.io.reader
read_observable(s), read_trajectory,
read_averages, read_checkpoint
checkpoint_path                     the checkpoint file beside an output file
                                    (jaxdpd.io.checkpoint: why, and its layout)
export                              frames to GSD, extended XYZ, LAMMPS data
                                    (jaxdpd.io.export; formats: jaxdpd.io.formats)
read_initial                        a scene's [initial] file (jaxdpd.io.initial)
RunFileError                        raised for files that cannot be read back
OutputError                         raised when writing the output fails
"""

from jaxdpd.io.checkpoint import checkpoint_path
from jaxdpd.io.errors import OutputError, RunFileError
from jaxdpd.io.h5md import H5MDWriter
from jaxdpd.io.pytree_store import read_tree, write_tree
from jaxdpd.io.reader import (
    Correlation,
    RadialDistribution,
    RunRecord,
    Series,
    load,
    read_averages,
    read_checkpoint,
    read_observable,
    read_observables,
    read_scene,
    read_state,
    read_trajectory,
)

__all__ = [
    "Correlation",
    "H5MDWriter",
    "OutputError",
    "RadialDistribution",
    "RunFileError",
    "RunRecord",
    "Series",
    "checkpoint_path",
    "load",
    "read_averages",
    "read_checkpoint",
    "read_observable",
    "read_observables",
    "read_scene",
    "read_state",
    "read_trajectory",
    "read_tree",
    "write_tree",
]
