"""Simulation boxes: how positions wrap and how separations are measured.

Every box kind is registered in `BOXES` under its scene name (box.kind); a box class
names the [flow] kind it carries (`flow_kind`, None for a box at rest) and builds
itself from the scene with `from_scene(lengths, flow)`.
"""

from jaxdpd.geometry.boxes.kraynik_reinelt import KraynikReineltBox, KraynikReineltState
from jaxdpd.geometry.boxes.lees_edwards import LeesEdwardsBox, LeesEdwardsState
from jaxdpd.geometry.boxes.periodic import PeriodicBox
from jaxdpd.registry import Registry

__all__ = [
    "BOXES",
    "KraynikReineltBox",
    "KraynikReineltState",
    "LeesEdwardsBox",
    "LeesEdwardsState",
    "PeriodicBox",
    "box_for_flow",
    "make_box",
]

BOXES = Registry("box kind", "box.kind")
BOXES.register(PeriodicBox)
BOXES.register(LeesEdwardsBox)
BOXES.register(KraynikReineltBox)


def make_box(kind: str, lengths, flow=None):
    """The static box of a scene.

    Args:
        kind: a registered box kind ("periodic", "lees_edwards", "kraynik_reinelt").
        lengths: (L_x, L_y, L_z).
        flow: the scene's Flow (shear rate and oscillation for a Lees–Edwards box,
            elongation rate and lattice case for a Kraynik–Reinelt box), or None.
    """
    return BOXES.get(kind).from_scene(tuple(float(length) for length in lengths), flow)


def box_for_flow(flow_kind: str | None) -> str:
    """The box kind that carries a [flow] of `flow_kind` (None: at rest)."""
    for box in BOXES:
        if box.flow_kind == flow_kind:
            return box.name
    raise ValueError(f"flow.kind = {flow_kind!r}: no registered box carries it")
