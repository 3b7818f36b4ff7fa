"""Simulation boxes: how positions wrap and how separations are measured."""

from jaxdpd.boxes.lees_edwards import LeesEdwardsBox, LeesEdwardsState
from jaxdpd.boxes.periodic import PeriodicBox

__all__ = ["LeesEdwardsBox", "LeesEdwardsState", "PeriodicBox", "make_box"]


def make_box(kind: str, lengths, flow=None):
    """The static box of a scene.

    Args:
        kind: "periodic" or "lees_edwards".
        lengths: (L_x, L_y, L_z).
        flow: the scene's Flow (shear rate, oscillation) for a Lees–Edwards box.
    """
    lengths = tuple(float(length) for length in lengths)
    if kind == "periodic":
        return PeriodicBox(lengths)
    if kind == "lees_edwards":
        rate = flow.shear_rate if flow is not None else 0.0
        frequency = flow.oscillation_frequency if flow is not None else None
        return LeesEdwardsBox(lengths, rate, frequency)
    raise ValueError(f"box.kind = {kind!r}; valid: 'periodic', 'lees_edwards'")
