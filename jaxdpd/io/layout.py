"""Names and units of the H5MD layout shared by the writer and the readers."""

UNITS = "reduced DPD units: r_c = m = k_BT = 1 (length r_c, time τ = r_c sqrt(m/k_BT))"
PARTICLES = "particles/all"
FRAME_ELEMENTS = ("position", "velocity", "image")
CHUNK_BYTES = 2**16  # target size of one HDF5 chunk of a time series

_UNITS_BY_NAME = {
    "position": "r_c",
    "edges": "r_c",
    "velocity": "r_c/τ",
    "time": "τ",
    "temperature": "k_BT",
    "pressure": "k_BT/r_c^3",
    "pressure_tensor": "k_BT/r_c^3",
}


def reduced_unit(name: str) -> str | None:
    """The reduced unit of an element named `name` (None when unknown)."""
    leaf = name.rsplit("/", 1)[-1]
    if "pressure_tensor_part/" in name:
        return _UNITS_BY_NAME["pressure_tensor"]
    if leaf.endswith("_sq"):
        return "r_c^2"
    return _UNITS_BY_NAME.get(leaf)
