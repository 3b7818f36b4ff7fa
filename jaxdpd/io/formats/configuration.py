"""One configuration of particles as the exchange formats hold it.

The common ground of GSD, extended XYZ and LAMMPS data files, in jaxdpd's reduced
units (lengths in r_c, velocities in r_c/τ, masses in m).  The periodic cell is given
by its lattice vectors a1, a2, a3 as the rows of `lattice`; jaxdpd's boxes are
restricted triclinic cells, a1 = (L_x, 0, 0), a2 = (Δ, L_y, 0), a3 = (0, 0, L_z), Δ
the Lees–Edwards offset (0 at rest), the form GSD and LAMMPS store; a
Kraynik–Reinelt cell is a general one (only extended XYZ stores it).
"""

from dataclasses import dataclass

import numpy as np


@dataclass
class Configuration:
    """Particles in a periodic cell at one step.

    Attributes:
        positions: (N, 3) Cartesian positions (any periodic image).
        lattice: (3, 3) lattice vectors as rows.
        species: (N,) species index of each particle into `species_names`.
        species_names: the species (particle type) names.
        velocities: (N, 3) velocities (jaxdpd's peculiar velocities), or None.
        image: (N, 3) image counters: unwrapped = positions + image @ lattice; or None.
        masses: (N,) particle masses, or None.
        bonds: (B, 2) bonded particle index pairs, or None when the file holds none.
        bond_types: (B,) bond type index into `bond_type_names`, or None.
        bond_type_names: the bond type names (the chained species' names).
        step: the time step of the configuration.
        time: its simulated time (units of τ).
    """

    positions: np.ndarray
    lattice: np.ndarray
    species: np.ndarray
    species_names: tuple[str, ...]
    velocities: np.ndarray | None = None
    image: np.ndarray | None = None
    masses: np.ndarray | None = None
    bonds: np.ndarray | None = None
    bond_types: np.ndarray | None = None
    bond_type_names: tuple[str, ...] = ()
    step: int = 0
    time: float = 0.0

    @property
    def n_particles(self) -> int:
        return len(self.positions)

    def unwrapped(self) -> np.ndarray:
        """(N, 3) positions + image @ lattice (the positions without image counters)."""
        if self.image is None:
            return np.asarray(self.positions, np.float64)
        return self.positions + self.image @ self.lattice


def fold(positions, image, lattice, low: float) -> tuple[np.ndarray, np.ndarray]:
    """(positions, image) with every position in the cell {s · lattice : s in
    [low, low + 1)³} and the counters (None: zeros) changed so that positions +
    image @ lattice is unchanged."""
    image = np.zeros(np.shape(positions), np.int64) if image is None else image
    shift = np.floor(positions @ np.linalg.inv(lattice) - low)
    return positions - shift @ lattice, (image + shift).astype(np.int32)


def restricted_triclinic(lattice, format_name: str) -> tuple[float, ...]:
    """(L_x, L_y, L_z, b_x, c_x, c_y) of a cell a1 = (L_x, 0, 0), a2 = (b_x, L_y, 0),
    a3 = (c_x, c_y, L_z), the only cells GSD and LAMMPS store.

    Raises:
        ValueError: the cell is not of that form (a Kraynik–Reinelt box).
    """
    lattice = np.asarray(lattice, np.float64)
    upper = lattice[[0, 0, 1], [1, 2, 2]]
    if np.any(upper != 0) or np.any(np.diag(lattice) <= 0):
        raise ValueError(
            f"{format_name} stores cells with a1 along x and a2 in the x–y plane; this "
            f"cell (rows {lattice.tolist()}) is a general one (a Kraynik–Reinelt box); "
            "export it as extended XYZ (--format xyz), which stores any lattice"
        )
    return (*np.diag(lattice), lattice[1, 0], lattice[2, 0], lattice[2, 1])


def minimum_image_chains(positions, lattice, bonds) -> np.ndarray:
    """(N, 3) positions with every bonded particle moved to the periodic image nearest
    its partner, in bond order (chains listed bead after bead come out whole): for
    files that carry no image counters."""
    positions = np.array(positions, np.float64)
    inverse = np.linalg.inv(lattice)
    for i, j in np.asarray(bonds):
        fraction = (positions[j] - positions[i]) @ inverse
        positions[j] = positions[i] + (fraction - np.round(fraction)) @ lattice
    return positions
