"""Names and units of the H5MD layout shared by the writer and the readers."""

import numpy as np

from jaxdpd.observables import OBSERVABLES

UNITS = "reduced DPD units: r_c = m = k_BT = 1 (length r_c, time τ = r_c sqrt(m/k_BT))"
# The particle group.  MDAnalysis builds its minimal topology only from a group named
# "trajectory" (MDAnalysis 2.11, H5MDReader.parse_n_atoms), so new files use that
# name; files written before (group "all") stay readable (`particle_group`).
PARTICLES = "particles/trajectory"
LEGACY_PARTICLES = "particles/all"
FRAME_ELEMENTS = ("position", "velocity", "image")
CHUNK_BYTES = 2**16  # target size of one HDF5 chunk of a time series
EXTENSION = ".h5md"  # of the files jaxdpd names; any other (".h5") is read alike

# Units of the particle and box elements; the observables' series carry theirs
# (jaxdpd.observables.component: `units`).  "1": dimensionless.
_UNITS_BY_NAME = {
    "position": "r_c",
    "edges": "r_c",
    "velocity": "r_c/τ",
    "image": "1",
    "mass": "m",
    "time": "τ",
    "lag_time": "τ",
}


def reduced_unit(name: str) -> str | None:
    """The reduced unit of an element named `name` (None when unknown): by its last
    path component, or for an observable's series by a unit key of a registered
    observable (a leaf name, or a group prefix ending in "/")."""
    leaf = name.rsplit("/", 1)[-1]
    if leaf in _UNITS_BY_NAME:
        return _UNITS_BY_NAME[leaf]
    for component in OBSERVABLES:
        for key, unit in component.units.items():
            if (key.endswith("/") and key in name) or key == leaf:
                return unit
    return None


def particle_group(handle) -> str:
    """The path of the particle group of an open file ("particles/trajectory", or
    "particles/all" in files written before the rename)."""
    return LEGACY_PARTICLES if LEGACY_PARTICLES in handle else PARTICLES


def scene_bonds(scene) -> np.ndarray:
    """(B, 2) int32 particle index pairs of every spring of the scene's chains
    (particles species after species, chains bead after bead:
    jaxdpd.geometry.chain_topology)."""
    pairs = [np.zeros((0, 2), np.int32)]
    for polymer in scene.polymers:
        first, count = scene.species_range(polymer.species)
        beads = np.arange(first, first + count, dtype=np.int32).reshape(-1, polymer.beads)
        pairs.append(np.stack([beads[:, :-1].ravel(), beads[:, 1:].ravel()], axis=1))
    return np.concatenate(pairs)
