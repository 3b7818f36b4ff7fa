"""Restoring a file's checkpointed state: build the stored scene, read the state into it.

jaxdpd.io reads files without the engine (nothing is built or compiled); a state needs
the template only a built simulation gives, so this is where the two meet.
"""

from jaxdpd.engine.build import build
from jaxdpd.io.reader import read_scene, read_state


def restore(path, simulation=None):
    """The simulation of a file's scene and its checkpointed state.

    Args:
        path: an H5MD file written by jaxdpd (its checkpoint beside it).
        simulation: the built simulation of the file's scene, to reuse one already
            built; None builds the stored scene.
    Returns:
        (simulation, state): the state with every leaf bit-identical to the
        checkpoint's, ready for `jaxdpd.run.driver.run(simulation, state, ...)`.
    Raises:
        RunFileError: the file or its checkpoint cannot be read back.
    """
    if simulation is None:
        simulation = build(read_scene(path))
    return simulation, read_state(path, simulation.init_fn())
