"""Export the frames of a jaxdpd H5MD file to GSD, extended XYZ or a LAMMPS data file.

Each stored frame (output.trajectory_every) becomes a Configuration
(jaxdpd.io.formats): positions, peculiar velocities, image counters, the frame's
box edges as lattice vectors (a Lees–Edwards frame's a2 = (Δ, L_y, 0) is the tilt of
the exported cell), species as particle types, masses, and the chains' springs as
bonds typed by their species.  Reading the file imports no part of the engine.
"""

import numpy as np

from jaxdpd.io.errors import RunFileError, open_run_file
from jaxdpd.io.formats import format_of
from jaxdpd.io.formats.configuration import Configuration
from jaxdpd.io.layout import particle_group, scene_bonds
from jaxdpd.io.reader import scene_of


def select_frames(spec: str, count: int) -> list[int]:
    """Frame indices of `spec`: "all", "last", an index ("-1", "3") or a slice
    ("::10", "5:"), of `count` frames.

    Raises:
        ValueError: a spec that is none of these, or selects no frame.
    """
    spec = spec.strip()
    if spec == "all":
        indices = list(range(count))
    elif spec == "last":
        indices = list(range(count))[-1:]
    else:
        try:
            if ":" in spec:
                parts = [int(p) if p.strip() else None for p in spec.split(":")]
                indices = list(range(count))[slice(*parts)]
            else:
                indices = [range(count)[int(spec)]]
        except (ValueError, IndexError, TypeError):
            raise ValueError(
                f"--frames {spec!r}: give all, last, an index or a slice start:stop:step "
                f"(the file holds {count} frames)"
            ) from None
    if not indices:
        raise ValueError(f"--frames {spec!r} selects none of the file's {count} frames")
    return indices


def read_configurations(path, frames: str = "all") -> tuple[list[Configuration], object]:
    """(the selected frames of a run file as Configurations, its Scene)."""
    with open_run_file(path) as handle:
        scene = scene_of(handle)
        group = particle_group(handle)
        if f"{group}/position" not in handle:
            raise RunFileError(
                f"{path}: holds no frames to export (the run had output.trajectory_every = 0; "
                "set it in the scene's [output], e.g. to a multiple of run.chunk, and run again)"
            )
        particles = handle[group]
        indices = select_frames(frames, len(particles["position/step"]))
        species = particles["species"][()].astype(np.int64)
        masses = particles["mass"][()] if "mass" in particles else None
        edges = particles["box/edges/value"]
        configurations = [
            Configuration(
                positions=particles["position/value"][k].astype(np.float64),
                lattice=_lattice(edges[k]),
                species=species,
                species_names=scene.species_names,
                velocities=particles["velocity/value"][k].astype(np.float64),
                image=particles["image/value"][k].astype(np.int64),
                masses=masses,
                step=int(particles["position/step"][k]),
                time=float(particles["position/time"][k]),
            )
            for k in indices
        ]
    bonds, bond_types = scene_bonds(scene), _bond_types(scene)
    for configuration in configurations:
        if len(bonds):
            configuration.bonds, configuration.bond_types = bonds, bond_types
            configuration.bond_type_names = tuple(p.species for p in scene.polymers)
    return configurations, scene


def _lattice(edges) -> np.ndarray:
    """Lattice vectors (rows) of an H5MD `edges` value: (3,) lengths or (3, 3) rows."""
    edges = np.asarray(edges, np.float64)
    return np.diag(edges) if edges.ndim == 1 else edges


def _bond_types(scene) -> np.ndarray:
    """(B,) polymer entry index of each spring, in `scene_bonds` order."""
    counts = [scene.species_range(p.species)[1] // p.beads * (p.beads - 1) for p in scene.polymers]
    return np.repeat(np.arange(len(counts)), counts)


def export(path, output, format_name: str | None = None, frames: str | None = None, **options):
    """Write frames of the run file `path` to `output` in a format (None: from the
    extension of `output`); `frames` defaults to all, or to the last for a format that
    holds one configuration.  `options` go to the format's writer (atom_style).

    Returns:
        The number of frames written.
    """
    module = format_of(output, format_name, field="--format")
    default = "all" if module.multi_frame else "last"
    configurations, _ = read_configurations(path, frames or default)
    module.write(output, configurations, **options)
    return len(configurations)
