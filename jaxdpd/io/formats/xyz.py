"""Extended XYZ (read by OVITO, ASE, VMD's molfile plugin as plain XYZ).

Each frame: the particle count, a comment line of key=value pairs, one line per
particle.  The comment holds `Lattice="a1 a2 a3"` (nine numbers, the lattice vectors
in turn, any cell: Kraynik–Reinelt ones too), `Properties=species:S:1:pos:R:3[:velo:R:3]`,
`Step`, `Time` and `pbc="T T T"`; positions are folded into the cell spanned from the
origin.  No image counters and no bonds: a run started from an XYZ file takes its
chains from the scene and makes them whole by minimum image.  Numbers are written
with 17 significant digits, so float64 values come back exactly.
Reference: github.com/libAtoms/extxyz (the format's specification).
"""

import re
import shlex

import numpy as np

from jaxdpd.io.formats.configuration import Configuration, fold

name = "xyz"
extensions = (".xyz", ".extxyz")
write_options = ()  # keyword arguments of write
multi_frame = True


def write(path, configurations) -> None:
    """Write the configurations as the frames of a new extended XYZ file."""
    with open(path, "w") as handle:
        for configuration in configurations:
            handle.write(_frame(configuration))


def _frame(configuration: Configuration) -> str:
    lattice = configuration.lattice
    positions, _ = fold(configuration.positions, None, lattice, 0.0)
    properties = "species:S:1:pos:R:3"
    columns = [positions]
    if configuration.velocities is not None:
        properties += ":velo:R:3"
        columns.append(configuration.velocities)
    numbers = np.concatenate(columns, axis=1)
    names = np.asarray(configuration.species_names, dtype=object)[configuration.species]
    lattice_text = " ".join(f"{v:.17g}" for v in lattice.ravel())
    header = (
        f'Lattice="{lattice_text}" Properties={properties} Step={configuration.step} '
        f'Time={configuration.time:.17g} pbc="T T T"'
    )
    rows = (
        f"{n} " + " ".join(f"{v:.17g}" for v in row) for n, row in zip(names, numbers, strict=True)
    )
    return f"{configuration.n_particles}\n{header}\n" + "\n".join(rows) + "\n"


def read(path, frame: int = -1) -> Configuration:
    """Frame `frame` (negative: from the end) of an extended XYZ file."""
    with open(path) as handle:
        lines = handle.read().splitlines()
    starts, k = [], 0
    while k < len(lines) and lines[k].strip():
        starts.append(k)
        k += int(lines[k]) + 2
    start = starts[range(len(starts))[frame]]
    n = int(lines[start])
    keys = dict(_pairs(lines[start + 1]))
    if "Lattice" not in keys:
        raise ValueError(f"{path}: frame {frame} has no Lattice= (not a periodic extended XYZ)")
    lattice = np.array(keys["Lattice"].split(), np.float64).reshape(3, 3)
    table = [line.split() for line in lines[start + 2 : start + 2 + n]]
    columns = _columns(keys.get("Properties", "species:S:1:pos:R:3"))
    names = [row[columns["species"][0]] for row in table]
    species_names = tuple(dict.fromkeys(names))

    def block(key):
        first, width = columns[key]
        return np.array([row[first : first + width] for row in table], np.float64)

    return Configuration(
        positions=block("pos"),
        lattice=lattice,
        species=np.array([species_names.index(n) for n in names]),
        species_names=species_names,
        velocities=block("velo") if "velo" in columns else None,
        step=int(keys.get("Step", 0)),
        time=float(keys.get("Time", 0.0)),
    )


def _pairs(comment: str):
    """(key, value) pairs of an extended XYZ comment line (values may be quoted)."""
    for token in shlex.split(comment):
        key, _, value = token.partition("=")
        yield key, value


def _columns(properties: str) -> dict:
    """{name: (first column, width)} of a Properties= specification."""
    fields = re.findall(r"([^:]+):([SRIL]):(\d+)", properties)
    columns, first = {}, 0
    for key, _, width in fields:
        columns[key] = (first, int(width))
        first += int(width)
    return columns
