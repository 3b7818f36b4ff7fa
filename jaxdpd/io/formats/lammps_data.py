"""LAMMPS data files (read_data; read by LAMMPS, OVITO, VMD's topotools, MDAnalysis).

One configuration per file (the last frame of a run, or a chosen one), atom_style
"bond" (atom-ID molecule-ID atom-type x y z nx ny nz) or "full" (… atom-type q x y z
…, charge 0); molecule IDs number the chains from 1, 0 for free particles.  Atom
types 1, 2, … are the species in order, named in comments of the Masses section
(`1 1.0  # solvent`); bond types 1, 2, … are the chained species.  The box is
0 ≤ x < L_x (etc.) with the tilt line `xy xz yz` when a Lees–Edwards offset tilts
it (xy = Δ: LAMMPS tilts are lengths); positions are folded into it, with image
flags.  Velocities are jaxdpd's peculiar velocities.  Numbers are written with 17
significant digits (exact float64).  Units: jaxdpd's reduced ones (LAMMPS
`units lj` with σ = r_c, m = 1, ε = k_BT).
Reference: docs.lammps.org/read_data.html.
"""

import re

import numpy as np

import jaxdpd
from jaxdpd.io.formats.configuration import Configuration, fold, restricted_triclinic

name = "lammps-data"
extensions = (".data", ".lmp", ".lammps")
write_options = ("atom_style",)  # keyword arguments of write
multi_frame = False
ATOM_STYLES = ("bond", "full")


def write(path, configurations, atom_style: str = "bond") -> None:
    """Write the one configuration in `configurations` as a LAMMPS data file."""
    if len(configurations) != 1:
        raise ValueError(
            f"a LAMMPS data file holds one configuration, {len(configurations)} were "
            "selected (choose one with --frames)"
        )
    if atom_style not in ATOM_STYLES:
        raise ValueError(f"atom_style {atom_style!r}: valid values are {list(ATOM_STYLES)}")
    (configuration,) = configurations
    with open(path, "w") as handle:
        handle.write(_text(configuration, atom_style))


def _number(value) -> str:
    return f"{value:.17g}"


def _text(configuration: Configuration, atom_style: str) -> str:
    lx, ly, lz, xy, xz, yz = restricted_triclinic(configuration.lattice, "A LAMMPS data file")
    positions, image = fold(configuration.positions, configuration.image, configuration.lattice, 0)
    bonds = configuration.bonds if configuration.bonds is not None else np.zeros((0, 2), int)
    n = configuration.n_particles
    molecule = _molecules(n, bonds)
    lines = [
        f"LAMMPS data file written by jaxdpd {jaxdpd.__version__}, step {configuration.step} "
        "(reduced DPD units: r_c = m = k_BT = 1)",
        "",
        f"{n} atoms",
        f"{len(configuration.species_names)} atom types",
        f"{len(bonds)} bonds",
        f"{max(1, len(configuration.bond_type_names)) if len(bonds) else 0} bond types",
        "",
        f"0 {_number(lx)} xlo xhi",
        f"0 {_number(ly)} ylo yhi",
        f"0 {_number(lz)} zlo zhi",
    ]
    if xy or xz or yz:
        lines.append(f"{_number(xy)} {_number(xz)} {_number(yz)} xy xz yz")
    masses = np.ones(n) if configuration.masses is None else configuration.masses
    lines += ["", "Masses", ""]
    for k, species in enumerate(configuration.species_names):
        members = masses[configuration.species == k]
        lines.append(f"{k + 1} {_number(members[0] if len(members) else 1.0)}  # {species}")
    lines += ["", f"Atoms  # {atom_style}", ""]
    charge = " 0" if atom_style == "full" else ""
    for i in range(n):
        xyz = " ".join(_number(v) for v in positions[i])
        flags = " ".join(str(v) for v in image[i])
        lines.append(f"{i + 1} {molecule[i]} {configuration.species[i] + 1}{charge} {xyz} {flags}")
    if configuration.velocities is not None:
        lines += ["", "Velocities", ""]
        for i, velocity in enumerate(configuration.velocities):
            lines.append(f"{i + 1} " + " ".join(_number(v) for v in velocity))
    if len(bonds):
        types = configuration.bond_types
        types = np.zeros(len(bonds), int) if types is None else types
        lines += ["", "Bonds", ""]
        for k, ((i, j), kind) in enumerate(zip(bonds, types, strict=True)):
            lines.append(f"{k + 1} {kind + 1} {i + 1} {j + 1}")
    return "\n".join(lines) + "\n"


def _molecules(n: int, bonds) -> np.ndarray:
    """(N,) molecule IDs: 1, 2, … for the chains (bonded clusters), 0 for free
    particles."""
    root = np.arange(n)

    def find(i):
        while root[i] != i:
            root[i] = root[root[i]]
            i = root[i]
        return i

    for i, j in bonds:
        root[find(j)] = find(i)
    chained = np.zeros(n, bool)
    chained[np.asarray(bonds, int).ravel()] = True
    roots = np.array([find(i) for i in range(n)])
    ids = {r: k + 1 for k, r in enumerate(dict.fromkeys(roots[chained]))}
    return np.array([ids.get(r, 0) if c else 0 for r, c in zip(roots, chained, strict=True)])


_SECTION = re.compile(r"^\s*([A-Z][A-Za-z ]*?)\s*(#.*)?$")


def read(path, frame: int = -1) -> Configuration:
    """The configuration of a LAMMPS data file written with atom_style bond or full
    (`frame` must select its one configuration: 0 or −1)."""
    if frame not in (0, -1):
        raise ValueError(f"{path}: a LAMMPS data file holds one configuration, not frame {frame}")
    with open(path) as handle:
        lines = handle.read().splitlines()
    header, sections, current = {}, {}, None
    lattice = np.zeros((3, 3))
    for line in lines[1:]:
        text = line.split("#")[0].strip()
        match = _SECTION.match(line)
        if match and not re.search(r"\d", match.group(1)):
            current = match.group(1)
            sections[current] = {"style": (match.group(2) or "").lstrip("# ").strip(), "rows": []}
            continue
        if not text:
            continue
        if current is not None:
            sections[current]["rows"].append((text.split(), line.partition("#")[2].strip()))
            continue
        words = text.split()
        for axis, key in enumerate(("xlo xhi", "ylo yhi", "zlo zhi")):
            if text.endswith(key):
                lattice[axis, axis] = float(words[1]) - float(words[0])
        if text.endswith("xy xz yz"):
            lattice[1, 0], lattice[2, 0], lattice[2, 1] = (float(w) for w in words[:3])
        elif len(words) >= 2 and words[0].isdigit():
            header[" ".join(words[1:])] = int(words[0])
    return _configuration(path, header, sections, lattice)


def _configuration(path, header, sections, lattice) -> Configuration:
    style = sections["Atoms"]["style"] or "bond"
    if style not in ATOM_STYLES:
        raise ValueError(f"{path}: Atoms section of style {style!r}; readable: {ATOM_STYLES}")
    first = 4 if style == "full" else 3  # column of x
    atoms = sorted(sections["Atoms"]["rows"], key=lambda row: int(row[0][0]))
    table = np.array([[float(v) for v in words] for words, _ in atoms])
    n_types = header.get("atom types", int(table[:, 2].max()))
    names = {int(w[0]): note for w, note in sections.get("Masses", {"rows": []})["rows"]}
    masses = {int(w[0]): float(w[1]) for w, _ in sections.get("Masses", {"rows": []})["rows"]}
    species = table[:, 2].astype(int) - 1
    configuration = Configuration(
        positions=table[:, first : first + 3],
        lattice=lattice,
        species=species,
        species_names=tuple(names.get(k + 1) or str(k + 1) for k in range(n_types)),
        image=table[:, first + 3 : first + 6].astype(np.int64)
        if table.shape[1] >= first + 6
        else None,
        masses=np.array([masses.get(k + 1, 1.0) for k in species]) if masses else None,
    )
    if "Velocities" in sections:
        rows = sorted(sections["Velocities"]["rows"], key=lambda row: int(row[0][0]))
        configuration.velocities = np.array([[float(v) for v in w[1:4]] for w, _ in rows])
    if "Bonds" in sections:
        bonds = np.array([[int(v) for v in w[:4]] for w, _ in sections["Bonds"]["rows"]])
        configuration.bonds = bonds[:, 2:4] - 1
        configuration.bond_types = bonds[:, 1] - 1
    return configuration
