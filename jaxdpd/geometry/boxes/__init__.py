"""Simulation boxes: how positions wrap and how separations are measured."""

from jaxdpd.geometry.boxes.kraynik_reinelt import KraynikReineltBox, KraynikReineltState
from jaxdpd.geometry.boxes.lees_edwards import LeesEdwardsBox, LeesEdwardsState
from jaxdpd.geometry.boxes.periodic import PeriodicBox

__all__ = [
    "KraynikReineltBox",
    "KraynikReineltState",
    "LeesEdwardsBox",
    "LeesEdwardsState",
    "PeriodicBox",
    "make_box",
]


def make_box(kind: str, lengths, flow=None):
    """The static box of a scene.

    Args:
        kind: "periodic", "lees_edwards" or "kraynik_reinelt".
        lengths: (L_x, L_y, L_z).
        flow: the scene's Flow (shear rate and oscillation for a Lees–Edwards box,
            elongation rate and lattice case for a Kraynik–Reinelt box).
    """
    lengths = tuple(float(length) for length in lengths)
    if kind == "periodic":
        return PeriodicBox(lengths)
    if kind == "lees_edwards":
        rate = flow.shear_rate if flow is not None else 0.0
        frequency = flow.oscillation_frequency if flow is not None else None
        return LeesEdwardsBox(lengths, rate, frequency)
    if kind == "kraynik_reinelt":
        if flow is None:
            return KraynikReineltBox(lengths)
        return KraynikReineltBox(lengths, flow.elongation_rate, flow.kraynik_reinelt_case)
    raise ValueError(f"box.kind = {kind!r}; valid: 'periodic', 'lees_edwards', 'kraynik_reinelt'")
