"""A run's initial configuration read from a scene's [initial] file.

The file (GSD, extended XYZ or LAMMPS data: jaxdpd.io.formats) must hold the scene's
particles in the scene's order: the same count, the species of each particle (by
name where the file names them: GSD types, XYZ species, the names jaxdpd writes in a
LAMMPS data file's Masses comments; else by type number), the scene's springs where
the file has bonds, and the scene's edge lengths (a tilt, a Lees–Edwards offset, is
allowed: the run starts from offset 0 with the unwrapped positions).  Positions are
unwrapped by the file's image counters, or, where it has none (XYZ), each chain is
made whole by minimum image.  Every mismatch is a SceneError naming initial.file.
"""

import numpy as np

from jaxdpd.io.formats import FILE_FORMATS
from jaxdpd.io.formats.configuration import minimum_image_chains
from jaxdpd.io.layout import scene_bonds
from jaxdpd.validation import SceneError

FIELD = "initial.file"


def read_initial(scene) -> dict:
    """{"positions": (N, 3), "velocities": (N, 3) or None} of the scene's [initial]
    file, checked against the scene (module docstring), for `init_fn(**...)`; {} for
    a scene without [initial].

    Raises:
        SceneError: the file cannot be read or does not fit the scene.
    """
    initial = scene.initial
    if initial is None:
        return {}
    try:
        configuration = FILE_FORMATS.get(initial.format).read(initial.file, initial.frame)
    except (ImportError, OSError, ValueError, KeyError, IndexError) as error:
        raise SceneError(
            FIELD, f"cannot read it as {initial.format} ({error})", initial.file
        ) from None
    _check(scene, configuration)
    bonds = scene_bonds(scene)
    if configuration.image is None and len(bonds):
        positions = minimum_image_chains(configuration.positions, configuration.lattice, bonds)
    else:
        positions = configuration.unwrapped()
    return {"positions": positions, "velocities": configuration.velocities}


def _check(scene, configuration) -> None:
    """Refuse a configuration whose particles, species, springs or box are not the
    scene's."""
    file = scene.initial.file

    def refuse(message):
        raise SceneError(FIELD, message, file)

    if configuration.n_particles != scene.n_particles:
        refuse(f"holds {configuration.n_particles} particles, the scene {scene.n_particles}")
    counts = [s.count for s in scene.particles.species]
    expected = np.repeat(np.arange(len(counts)), counts)
    names = configuration.species_names
    if all(name in scene.species_names for name in names):
        found = np.array([scene.species_names.index(n) for n in names])[configuration.species]
    else:  # types by number (a LAMMPS data file without names)
        found = configuration.species
    wrong = np.flatnonzero(found != expected)
    if len(wrong):
        k = wrong[0]
        refuse(
            f"particle {k} is of species {names[configuration.species[k]]!r}, the scene "
            f"has {scene.species_names[expected[k]]!r} there (species {list(scene.species_names)} "
            f"with counts {counts}, in this order)"
        )
    bonds = scene_bonds(scene)
    if configuration.bonds is not None:
        given = {tuple(sorted(pair)) for pair in np.asarray(configuration.bonds).tolist()}
        if given != {tuple(pair) for pair in bonds.tolist()}:
            refuse(
                f"its {len(given)} bonds are not the scene's {len(bonds)} springs "
                "([[polymers]]: chains of consecutive particles of a species)"
            )
    lengths = np.diag(configuration.lattice)
    if not np.allclose(lengths, scene.box.lengths, rtol=1e-6, atol=0):
        refuse(f"its box edges {lengths.tolist()} are not box.lengths {list(scene.box.lengths)}")
