"""Names and units of the H5MD layout shared by the writer and the readers."""

from jaxdpd.observables import OBSERVABLES

UNITS = "reduced DPD units: r_c = m = k_BT = 1 (length r_c, time τ = r_c sqrt(m/k_BT))"
PARTICLES = "particles/all"
FRAME_ELEMENTS = ("position", "velocity", "image")
CHUNK_BYTES = 2**16  # target size of one HDF5 chunk of a time series

# Units of the particle and box elements; the observables' series carry theirs
# (jaxdpd.observables.component: `units`).
_UNITS_BY_NAME = {
    "position": "r_c",
    "edges": "r_c",
    "velocity": "r_c/τ",
    "time": "τ",
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
