"""Simulation boxes: how positions wrap and how separations are measured."""

from jaxdpd.boxes.periodic import PeriodicBox

__all__ = ["PeriodicBox"]
