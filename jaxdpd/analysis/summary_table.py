"""The summary table of a run as text: each row's mean, standard error and unit, in
columns as wide as the longest name, and a glossary of the names.

Units are reduced DPD units (r_c = m = k_BT = 1, τ = r_c sqrt(m/k_BT)).  A per-step
series carries the unit its H5MD element is labelled with (jaxdpd.io.layout); the
derived rows (material functions, drag, diffusion, tensor components) take theirs
from GLOSSARY.
"""

import numpy as np

from jaxdpd.io.layout import reduced_unit

PRESSURE = "k_BT/r_c^3"
VISCOSITY = "k_BT τ/r_c^3"
NORMAL_STRESS = "k_BT τ^2/r_c^3"
FRICTION = "m/τ"

# Last path component of a row name, or a group prefix ending in "/" -> (unit, meaning).
GLOSSARY = {
    "temperature": ("k_BT", "kinetic temperature, 2/3 of the mean peculiar kinetic energy"),
    "pressure": (PRESSURE, "virial pressure, a third of the trace of the pressure tensor"),
    "P_xy": (PRESSURE, "shear component xy of the pressure tensor (x flow, y gradient)"),
    "P_yx": (PRESSURE, "component yx of the pressure tensor"),
    "P_xx": (PRESSURE, "normal component xx of the pressure tensor"),
    "P_yy": (PRESSURE, "normal component yy of the pressure tensor"),
    "P_zz": (PRESSURE, "normal component zz of the pressure tensor"),
    "N1": (PRESSURE, "first normal stress difference N1 = σ_xx − σ_yy = P_yy − P_xx (shear)"),
    "N2": (PRESSURE, "second normal stress difference N2 = σ_yy − σ_zz = P_zz − P_yy (shear)"),
    "viscosity": (VISCOSITY, "shear viscosity η = −P_xy/γ̇ (polymer/: spring part)"),
    "viscosity_part/": (VISCOSITY, "the part of η due to one force (bond, conservative, ...)"),
    "psi1": (NORMAL_STRESS, "first normal stress coefficient Ψ1 = −(P_xx − P_yy)/γ̇²"),
    "psi2": (NORMAL_STRESS, "second normal stress coefficient Ψ2 = −(P_yy − P_zz)/γ̇²"),
    "eta1": (
        VISCOSITY,
        "planar elongational viscosity η̄1 = (P_xx − P_zz)/ε̇ (z stretches, x compresses; "
        "4η for a Newtonian fluid; polymer/: spring part)",
    ),
    "eta2": (
        VISCOSITY,
        "second planar elongational viscosity η̄2 = (P_xx − P_yy)/ε̇ (y neutral; 2η for a "
        "Newtonian fluid)",
    ),
    "bond_length_sq": ("r_c^2", "mean squared spring length ⟨Q²⟩"),
    "end_to_end_sq": ("r_c^2", "mean squared end-to-end distance ⟨R_e²⟩"),
    "gyration_radius_sq": ("r_c^2", "mean squared radius of gyration ⟨R_g²⟩"),
    "fractional_extension": ("1", "⟨|R_e|⟩/L_c, L_c the contour length"),
    "fractional_extension_sq": ("1", "⟨R_e²⟩/L_c²"),
    "bond_conformation_xy": ("r_c^2", "⟨Q_x Q_y⟩ of the springs (shear)"),
    "bond_conformation_xx-yy": ("r_c^2", "⟨Q_x²⟩ − ⟨Q_y²⟩ of the springs (first difference)"),
    "bond_conformation_yy-zz": ("r_c^2", "⟨Q_y²⟩ − ⟨Q_z²⟩ of the springs (second difference)"),
    "drag_giesekus": (
        FRICTION,
        "bead drag ζ from the Giesekus stress expression (thesis eq. 4.18)",
    ),
    "drag_giesekus_ev": (FRICTION, "drag_giesekus with the bead repulsion across springs"),
    "zeta": (FRICTION, "drag coefficient of the tagged particles, force/mean velocity"),
    "D_CM": ("r_c^2/τ", "centre-of-mass diffusion coefficient from the slope of g3"),
    "particle-steps/s": ("1/s", "particles × steps per wall-clock second after compiling"),
    "g(r) first peak at r": ("r_c", "position of the first maximum of g(r)"),
    "g(r) first peak height": ("1", "g(r) at its first maximum"),
}


def _entry(name: str):
    """(key, (unit, meaning)) of a row name in GLOSSARY, or None."""
    leaf = name.rsplit("/", 1)[-1]
    if leaf in GLOSSARY:
        return leaf, GLOSSARY[leaf]
    for key, entry in GLOSSARY.items():
        if key.endswith("/") and name.startswith(key):
            return key, entry
    return None


def row_unit(name: str) -> str:
    """The reduced unit of a summary row ("" when unknown)."""
    entry = _entry(name)
    return entry[1][0] if entry is not None else reduced_unit(name) or ""


def format_table(
    rows: dict,
    references: dict | None = None,
    warnings: dict | None = None,
    extra: dict | None = None,
    notes: dict | None = None,
) -> str:
    """The summary as text, one row per line, starting with its name.

    Args:
        rows: name -> (mean, standard error).
        references: name -> exact value for ideal chains, shown beside the mean.
        warnings: name -> message of a failed sanity check: the row is marked
            "<- WARNING" and the message follows the table on a line "WARNING: ...".
        extra: name -> (value, remark) rows without an error (rate, g(r) peak).
        notes: name -> short remark after a row (e.g. the blocking verdict).
    """
    references, warnings = references or {}, warnings or {}
    extra, notes = extra or {}, notes or {}
    width = max(len(name) for name in ["observable", *rows, *extra]) + 2
    # The ideal-chain column only when some row has a reference (a polymer run).
    column = 12 if references else 0
    header = f"{'observable':<{width}}{'mean':>14}{'± s.e.':>12}  {'unit':<14}"
    lines = [(header + (f"{'ideal chain':>12}" if references else "")).rstrip()]
    for name, (mean, error) in rows.items():
        reference = references.get(name)
        ideal = f"{reference:>12.6g}" if reference is not None else " " * column
        note = f"  {notes[name]}" if name in notes else ""
        mark = "  <- WARNING" if name in warnings else ""
        line = f"{name:<{width}}{mean:>14.6g}{error:>12.2g}  {row_unit(name):<14}{ideal}{note}"
        lines.append((line.rstrip() + mark) if mark else line.rstrip())
    for name, (value, remark) in extra.items():
        lines.append(f"{name:<{width}}{value:>14.4g}{remark:>12}  {row_unit(name)}".rstrip())
    lines.extend(f"WARNING: {message}" for message in warnings.values())
    return "\n".join(lines)


def rdf_rows(r, g) -> dict:
    """The `extra` rows of g(r): position and height of its maximum."""
    peak = int(np.nanargmax(g))
    return {"g(r) first peak at r": (r[peak], ""), "g(r) first peak height": (g[peak], "")}


def glossary(names) -> str:
    """One line per distinct name among `names` (by its GLOSSARY key, or its last path
    component): what it means and its unit."""
    entries = {}
    for name in names:
        key, entry = _entry(name) or (
            name.rsplit("/", 1)[-1],
            (row_unit(name), "run average of the per-step series of that name"),
        )
        entries.setdefault(key, entry)
    width = max(map(len, entries), default=0)
    lines = [
        f"  {key:<{width}}  {meaning} [{unit or '?'}]" for key, (unit, meaning) in entries.items()
    ]
    return "\n".join(
        [
            "glossary (reduced units r_c = m = k_BT = 1, τ = r_c sqrt(m/k_BT); a name "
            "<species>/x is x of that polymer species):",
            *lines,
        ]
    )
