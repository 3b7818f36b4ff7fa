"""Velocity-gradient tensors of homogeneous flows, in dumbbell units.

The velocity field is ``v(r) = kappa . r`` with ``kappa_ij = dv_i/dx_j``.  Rates are
dimensionless, ``De = lambda_H * rate`` (Deborah/Weissenberg number of the thesis,
eq. 4.10: kappa_hat = kappa * lambda_H), with ``lambda_H = zeta / (4 H)`` (eq. 4.3).

==========================  ===========================================  ==========
flow                        kappa (rows i, columns j)                    rate
==========================  ===========================================  ==========
``equilibrium``             0                                            ignored
``shear``                   kappa_xy = rate (v_x = rate * y)             shear rate
``planar_elongation``       diag(-rate, 0, rate)                         eps_dot
``uniaxial_elongation``     diag(rate, -rate/2, -rate/2)                 eps_dot
==========================  ===========================================  ==========

All are traceless (incompressible).  Planar elongation stretches along z, compresses
along x and leaves y neutral, the convention of the DPD flows and the Kraynik–Reinelt
box (jaxdpd.geometry.flows, thesis eq. 5.12; docs/conventions.md).  Reference: Bird,
Armstrong & Hassager, *Dynamics of Polymeric Liquids* vol. 1, 2nd ed. (1987), ch. 3
(shear and shear-free flows); Clarke thesis ch. 4 (shear and planar elongation).
"""

from __future__ import annotations

import jax.numpy as jnp
import numpy as np

from jaxdpd.brownian._checks import concrete, float_dtype

__all__ = ["FLOWS", "velocity_gradient", "check_flow"]

FLOWS = ("equilibrium", "shear", "planar_elongation", "uniaxial_elongation")

_PATTERNS = {
    "equilibrium": np.zeros((3, 3)),
    "shear": np.array([[0.0, 1.0, 0.0], [0.0, 0.0, 0.0], [0.0, 0.0, 0.0]]),
    "planar_elongation": np.diag([-1.0, 0.0, 1.0]),
    "uniaxial_elongation": np.diag([1.0, -0.5, -0.5]),
}


def check_flow(flow) -> str:
    """Return ``flow`` if it names a known flow, else raise ValueError."""
    if not isinstance(flow, str) or flow not in FLOWS:
        raise ValueError(f"flow must be one of {FLOWS}, got {flow!r}")
    return flow


def velocity_gradient(flow: str, rate=0.0, dtype=jnp.float64):
    """Velocity-gradient tensor ``kappa`` (dimensionless, units 1/lambda_H).

    Args:
      flow: one of :data:`FLOWS`.
      rate: dimensionless rate ``De`` (shear rate or elongation rate times lambda_H),
        scalar or array of any shape; finite and >= 0.
      dtype: float32 or float64.

    Returns:
      ``kappa`` of shape ``rate.shape + (3, 3)``, ``kappa[..., i, j] = dv_i/dx_j``.
    """
    check_flow(flow)
    dt = float_dtype(dtype)
    arr = concrete(rate)
    if arr is not None and (np.any(~np.isfinite(arr)) or np.any(arr < 0)):
        raise ValueError(f"rate must be finite and in [0, inf), got {arr}")
    rate = jnp.asarray(rate, dtype=dt)
    return rate[..., None, None] * jnp.asarray(_PATTERNS[flow], dtype=dt)
