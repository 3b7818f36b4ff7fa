"""GSD, HOOMD-blue's trajectory format (read by HOOMD, OVITO, MDAnalysis, freud).

Needs the optional `gsd` package (`pip install jaxdpd[export]`).  HOOMD's box is
[L_x, L_y, L_z, xy, xz, yz] with tilt *factors*: a2 = (xy L_y, L_y, 0),
a3 = (xz L_z, yz L_z, L_z), so a Lees–Edwards offset Δ is xy = Δ/L_y; positions lie in
the cell centred on the origin (HOOMD's convention), so they are jaxdpd's shifted by
−(a1 + a2 + a3)/2 and folded into it, the image counters changed to match (the
unwrapped positions are unchanged).  GSD stores positions and velocities in float32.
Reference: gsd.readthedocs.io, "HOOMD schema".
"""

import numpy as np

from jaxdpd.io.formats.configuration import Configuration, fold, restricted_triclinic

name = "gsd"
extensions = (".gsd",)
write_options = ()  # keyword arguments of write
multi_frame = True


def _gsd_hoomd():
    try:
        import gsd.hoomd
    except ImportError:
        raise ImportError(
            "the GSD format needs the gsd package: pip install 'jaxdpd[export]' (or gsd)"
        ) from None
    return gsd.hoomd


def write(path, configurations) -> None:
    """Write the configurations as the frames of a new GSD file."""
    hoomd = _gsd_hoomd()
    with hoomd.open(str(path), mode="w") as trajectory:
        for configuration in configurations:
            trajectory.append(_frame(hoomd, configuration))


def _frame(hoomd, configuration: Configuration):
    lx, ly, lz, bx, cx, cy = restricted_triclinic(configuration.lattice, "GSD")
    lattice = configuration.lattice
    centre = lattice.sum(axis=0) / 2
    positions, image = fold(configuration.positions - centre, configuration.image, lattice, -0.5)
    frame = hoomd.Frame()
    frame.configuration.step = int(configuration.step)
    frame.configuration.box = [lx, ly, lz, bx / ly, cx / lz, cy / lz]
    particles = frame.particles
    particles.N = configuration.n_particles
    particles.types = list(configuration.species_names)
    particles.typeid = np.asarray(configuration.species, np.uint32)
    particles.position = positions.astype(np.float32)
    particles.image = image
    if configuration.velocities is not None:
        particles.velocity = np.asarray(configuration.velocities, np.float32)
    if configuration.masses is not None:
        particles.mass = np.asarray(configuration.masses, np.float32)
    if configuration.bonds is not None and len(configuration.bonds):
        frame.bonds.N = len(configuration.bonds)
        frame.bonds.types = list(configuration.bond_type_names)
        frame.bonds.typeid = np.asarray(configuration.bond_types, np.uint32)
        frame.bonds.group = np.asarray(configuration.bonds, np.uint32)
    return frame


def read(path, frame: int = -1) -> Configuration:
    """Frame `frame` (negative: from the end) of a GSD file."""
    hoomd = _gsd_hoomd()
    with hoomd.open(str(path), mode="r") as trajectory:
        index = range(len(trajectory))[frame]
        snapshot = trajectory[index]
        # GSD fills what a file does not store with defaults (zero velocities).
        has_velocities = any(
            trajectory.file.chunk_exists(frame=k, name="particles/velocity") for k in (index, 0)
        )
    lx, ly, lz, xy, xz, yz = (float(v) for v in snapshot.configuration.box)
    lattice = np.array([[lx, 0, 0], [xy * ly, ly, 0], [xz * lz, yz * lz, lz]])
    particles = snapshot.particles
    bonds = snapshot.bonds
    return Configuration(
        positions=particles.position.astype(np.float64) + lattice.sum(axis=0) / 2,
        lattice=lattice,
        species=particles.typeid.astype(np.int64),
        species_names=tuple(particles.types),
        velocities=particles.velocity.astype(np.float64) if has_velocities else None,
        image=particles.image.astype(np.int64),
        masses=particles.mass.astype(np.float64),
        bonds=bonds.group.astype(np.int64) if bonds.N else None,
        bond_types=bonds.typeid.astype(np.int64) if bonds.N else None,
        bond_type_names=tuple(bonds.types or ()),
        step=int(snapshot.configuration.step),
    )
