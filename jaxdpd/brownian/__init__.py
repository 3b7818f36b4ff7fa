"""Brownian dynamics of dilute dumbbells: the reference method for DPD polymer rheology.

Dimensionless units of the Clarke thesis (eq. 4.10): length ``sqrt(k_B T / H)``, time
``lambda_H = zeta / (4 H)``; rates are Deborah numbers ``De = lambda_H * rate``.

Modules, one concept each:

- :mod:`~jaxdpd.brownian.flows`: velocity gradients ``kappa`` of shear, planar and
  uniaxial elongation.
- :mod:`~jaxdpd.brownian.springs`: :class:`Hookean` and :class:`FENE` spring laws.
- :mod:`~jaxdpd.brownian.dynamics`: Öttinger's semi-implicit predictor–corrector
  (thesis eq. 4.9), ``simulate`` in ``lax.scan``.
- :mod:`~jaxdpd.brownian.rheology`: Kramers stress, material functions, ``flow_curve``
  (many rates, one jitted vmapped call, block-average error bars).
- :mod:`~jaxdpd.brownian.fit`: pathwise and likelihood-ratio sensitivities, optax fit.

Example::

    import jax, jaxdpd
    from jaxdpd import brownian as bd
    curve = bd.flow_curve(jax.random.key(0), "shear", [0.1, 1.0, 10.0], bd.FENE(50.0),
                          n_dumbbells=4096, dt=0.01, n_equilibrate=500, n_samples=200)
    eta, eta_err = curve["viscosity"]
"""

from jaxdpd.brownian.dynamics import (
    DumbbellState,
    equilibrium_state,
    ottinger_step,
    predictor_corrector,
    simulate,
    state_from_connectors,
    wiener_increments,
)
from jaxdpd.brownian.fit import (
    FitResult,
    Sensitivity,
    fit_spring,
    likelihood_ratio_sensitivity,
    log_transition_density,
    pathwise_sensitivity,
    stationary_average,
)
from jaxdpd.brownian.flows import FLOWS, velocity_gradient
from jaxdpd.brownian.rheology import (
    MATERIAL_FUNCTIONS,
    FlowCurve,
    ensemble_moments,
    flow_curve,
    flow_curves,
    kramers_stress,
    material_functions,
)
from jaxdpd.brownian.springs import FENE, Hookean

__all__ = [
    "FENE",
    "FLOWS",
    "MATERIAL_FUNCTIONS",
    "DumbbellState",
    "FitResult",
    "FlowCurve",
    "Hookean",
    "Sensitivity",
    "ensemble_moments",
    "equilibrium_state",
    "fit_spring",
    "flow_curve",
    "flow_curves",
    "kramers_stress",
    "likelihood_ratio_sensitivity",
    "log_transition_density",
    "material_functions",
    "ottinger_step",
    "pathwise_sensitivity",
    "predictor_corrector",
    "simulate",
    "state_from_connectors",
    "stationary_average",
    "velocity_gradient",
    "wiener_increments",
]
