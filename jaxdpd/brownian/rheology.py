"""Kramers stress, material functions and flow curves of dilute dumbbell solutions.

Polymer stress (Kramers form, Clarke thesis eq. 4.11; Bird et al., *Dynamics of
Polymeric Liquids* vol. 2, 2nd ed. (1987), ch. 13)::

    tau_p / (n k_B T) = - < f(Q^2) Q Q > + I

(``tau`` is the momentum-flux convention of Bird et al.: ``tau = -sigma``).  Material
functions in units of ``n k_B T lambda_H`` (viscosities) and ``n k_B T lambda_H^2``
(normal-stress coefficients), with ``De = lambda_H * rate``:

=====================  ======================================  ============== =========
flow                   material function                       formula        reference
=====================  ======================================  ============== =========
shear                  ``viscosity`` eta_p                     -tau_xy / De   eq. 4.12
shear                  ``psi1`` Psi_1                          -(tau_xx - tau_yy) / De^2   eq. 4.13
shear                  ``psi2`` Psi_2                          -(tau_yy - tau_zz) / De^2   BAH §3.3
planar_elongation      ``elongational_viscosity_1`` eta_bar_1  -(tau_xx - tau_yy) / De   BAH §3.3
planar_elongation      ``elongational_viscosity_2`` eta_bar_2  -(tau_zz - tau_yy) / De   BAH §3.3
uniaxial_elongation    ``elongational_viscosity`` eta_bar      -(tau_xx - tau_yy) / De   BAH §3.3
all                    ``q2`` <Q^2>; ``extension2`` <Q^2>/Q_0^2 (thesis Fig. 4-10);
                       ``extension`` <|Q|>/Q_0 (NaN for Hookean springs)
=====================  ======================================  ============== =========

In the linear (Newtonian) limit the polymer stress is ``-eta_p0 (kappa + kappa^T)``, so
the Trouton ratios are ``eta_bar_1/eta_p0 = 4`` (planar) and ``eta_bar/eta_p0 = 3``
(uniaxial).

Error bars are block averages (:func:`jaxdpd.statistics.block_average`) of the time
series of ensemble means; every material function is linear in the ensemble mean of
``f Q Q`` at one time, so its per-sample series is block-averaged directly (the
extension uses ``<|Q|>``, also linear).

**Variance reduction** (``variance_reduction=True``): a twin ensemble at rest with the
same initial connectors and the same Wiener increments is run alongside, and its
stress is subtracted as a control variate (Bonvin & Picasso, J. Non-Newtonian Fluid
Mech. 84, 191 (1999); Öttinger, *Stochastic Processes in Polymeric Fluids*, §4.2).  The
quantities used for material functions (off-diagonal stresses and normal-stress
differences) have mean exactly zero at rest by isotropy, also for the discrete scheme,
so the estimate stays unbiased, while at low De, where flow and twin trajectories stay
close, its variance drops by orders of magnitude.  Cost: twice the steps.  The
conformation quantities (``q2``, ``extension``) are not variance-reduced.
"""

from __future__ import annotations

import dataclasses
import functools

import jax
import jax.numpy as jnp
import numpy as np

from jaxdpd.brownian._checks import check_count, check_positive, float_dtype
from jaxdpd.brownian.dynamics import check_noise, equilibrium_state, simulate
from jaxdpd.brownian.flows import check_flow, velocity_gradient
from jaxdpd.brownian.springs import check_spring
from jaxdpd.statistics import block_average

__all__ = [
    "kramers_tensor",
    "ensemble_moments",
    "kramers_stress",
    "material_functions",
    "MATERIAL_FUNCTIONS",
    "FlowCurve",
    "flow_curve",
]

MATERIAL_FUNCTIONS = {
    "equilibrium": (),
    "shear": ("viscosity", "psi1", "psi2"),
    "planar_elongation": ("elongational_viscosity_1", "elongational_viscosity_2"),
    "uniaxial_elongation": ("elongational_viscosity",),
}
CONFORMATION = ("q2", "extension2", "extension")


def kramers_tensor(q, spring):
    """Per-dumbbell ``f(Q^2) Q Q``; ``q`` of shape ``(..., 3)`` -> ``(..., 3, 3)``."""
    f = spring.force_factor(jnp.sum(q * q, axis=-1))
    return f[..., None, None] * q[..., :, None] * q[..., None, :]


def ensemble_moments(connector, spring, n_groups: int = 1):
    """Ensemble means needed for the stress and the extension.

    Args:
      connector: ``(N, 3)`` connectors (units ``sqrt(k_B T/H)``).
      spring: the spring law.
      n_groups: split the ensemble into this many equal, consecutive groups (dumbbells
        are independent, so group means are independent: error bars without any
        correlation-time assumption); ``N`` must be a multiple.

    Returns:
      dict with ``fqq`` = ``<f Q Q>`` of shape ``(3, 3)`` (``(G, 3, 3)`` if
      ``n_groups > 1``), ``q2`` = ``<Q^2>`` and ``q`` = ``<|Q|>`` (``()`` or ``(G,)``).
    """
    n = connector.shape[0]
    if n % n_groups:
        raise ValueError(f"n_dumbbells={n} must be a multiple of n_groups={n_groups}")
    c = connector.reshape(n_groups, n // n_groups, 3)
    q2 = jnp.sum(c * c, axis=-1)
    f = spring.force_factor(q2)
    fqq = jnp.einsum("gn,gni,gnj->gij", f, c, c) / c.shape[1]
    out = {"fqq": fqq, "q2": jnp.mean(q2, axis=-1), "q": jnp.mean(jnp.sqrt(q2), axis=-1)}
    return out if n_groups > 1 else jax.tree.map(lambda x: x[0], out)


def kramers_stress(connector, spring):
    """Polymer stress ``tau_p/(n k_B T) = I - <f Q Q>`` (thesis eq. 4.11); ``(3, 3)``."""
    fqq = ensemble_moments(connector, spring)["fqq"]
    return jnp.eye(3, dtype=fqq.dtype) - fqq


def material_functions(flow: str, rate, fqq, q2=None, q=None, spring=None):
    """Material functions from ``<f Q Q>`` (and optionally the conformation).

    Args:
      flow: one of :data:`jaxdpd.brownian.flows.FLOWS`.
      rate: dimensionless rate ``De`` (> 0 for flows with material functions); scalar
        or broadcastable against ``fqq[..., 0, 0]``.
      fqq: ``(..., 3, 3)`` ensemble means ``<f Q Q>``.
      q2, q: ``(...)`` ensemble means of ``Q^2`` and ``|Q|`` (optional).
      spring: needed with ``q2``/``q`` for the extension (``Q_0^2 = b``).

    Returns:
      dict name -> ``(...)`` array, names as in the module table.  Units: viscosities
      in ``n k_B T lambda_H``, normal-stress coefficients in ``n k_B T lambda_H^2``.
    """
    check_flow(flow)
    # tau = I - fqq; differences of tau are minus differences of fqq.
    d = {}
    if flow == "shear":
        d["viscosity"] = fqq[..., 0, 1] / rate
        d["psi1"] = (fqq[..., 0, 0] - fqq[..., 1, 1]) / rate**2
        d["psi2"] = (fqq[..., 1, 1] - fqq[..., 2, 2]) / rate**2
    elif flow == "planar_elongation":
        d["elongational_viscosity_1"] = (fqq[..., 0, 0] - fqq[..., 1, 1]) / rate
        d["elongational_viscosity_2"] = (fqq[..., 2, 2] - fqq[..., 1, 1]) / rate
    elif flow == "uniaxial_elongation":
        d["elongational_viscosity"] = (fqq[..., 0, 0] - fqq[..., 1, 1]) / rate
    if q2 is not None:
        d["q2"] = q2
        if spring is not None:
            q_max2 = spring.max_q2(q2.dtype)
            nan = jnp.asarray(jnp.nan, dtype=q2.dtype)
            finite = jnp.isfinite(q_max2)
            d["extension2"] = jnp.where(finite, q2 / q_max2, nan)
            if q is not None:
                d["extension"] = jnp.where(finite, q / jnp.sqrt(q_max2), nan)
    return d


@dataclasses.dataclass(frozen=True)
class FlowCurve:
    """Steady-state material functions at a list of rates (NumPy arrays).

    Attributes:
      flow: the flow name.
      rates: ``(R,)`` dimensionless rates De.
      values: dict name -> ``(R,)`` time- and ensemble-averaged values.
      errors: dict name -> ``(R,)`` standard errors (block averages, see ``blocks``).
      series: dict name -> ``(R, S)`` ensemble-mean time series (S samples after
        equilibration), e.g. for a time-block or autocorrelation analysis.
      blocks: ``"ensemble"`` or ``"time"``: how ``errors`` were computed.
      guard_hits: ``(R,)`` number of times the FENE rounding guard acted (0 expected).
      max_extension2: ``(R,)`` largest ``Q^2/Q_0^2`` seen at any step (< 1 always).
      dt: ``(R,)`` time steps used; ``t_average``: ``(R,)`` averaging time (lambda_H).
    """

    flow: str
    rates: np.ndarray
    values: dict
    errors: dict
    series: dict
    blocks: str
    guard_hits: np.ndarray
    max_extension2: np.ndarray
    dt: np.ndarray
    t_average: np.ndarray

    def __getitem__(self, name):
        """``curve[name] -> (values[name], errors[name])``."""
        return self.values[name], self.errors[name]


_STATIC = (
    "flow",
    "n_dumbbells",
    "n_equilibrate",
    "n_samples",
    "sample_every",
    "n_blocks",
    "blocks",
    "dtype",
    "variance_reduction",
    "common_noise",
    "noise",
)


@functools.partial(jax.jit, static_argnames=_STATIC)
def _flow_curve_core(
    key,
    rates,
    dts,
    spring,
    *,
    flow,
    n_dumbbells,
    n_equilibrate,
    n_samples,
    sample_every,
    n_blocks,
    blocks,
    dtype,
    variance_reduction,
    common_noise,
    noise,
):
    k_init, k_noise = jax.random.split(key)
    n_rates = rates.shape[0]
    if common_noise:
        init_keys = jnp.stack([k_init] * n_rates)
        noise_keys = jnp.stack([k_noise] * n_rates)
    else:
        init_keys = jax.random.split(k_init, n_rates)
        noise_keys = jax.random.split(k_noise, n_rates)
    n_groups = n_blocks if blocks == "ensemble" else 1

    def one_rate(k_i, k_n, rate, dt):
        state0 = equilibrium_state(k_i, spring, n_dumbbells, dtype)
        kappa = velocity_gradient(flow, rate, dtype)
        kappas = jnp.stack([kappa, jnp.zeros_like(kappa)]) if variance_reduction else kappa[None]

        def run(kap):
            state = state0
            if n_equilibrate:
                state, _ = simulate(
                    k_n, state, kap, spring, dt, n_samples=1, sample_every=n_equilibrate,
                    observe=lambda c, s: None, noise=noise,
                )  # fmt: skip
            return simulate(
                k_n, state, kap, spring, dt, n_samples=n_samples, sample_every=sample_every,
                observe=lambda c, s: ensemble_moments(c, s, n_groups), noise=noise,
            )  # fmt: skip

        final, samples = jax.vmap(run)(kappas)
        fqq = samples["fqq"][0]
        if variance_reduction:
            fqq = fqq - samples["fqq"][1]
        # Per-sample (and per-group) material functions: (S,) or (S, G).
        rate_b = rate if n_groups == 1 else rate[..., None]
        mf = material_functions(flow, rate_b, fqq, samples["q2"][0], samples["q"][0], spring=spring)
        if n_groups > 1:
            stats = {k: block_average(jnp.mean(v, axis=0), n_groups) for k, v in mf.items()}
            series = {k: jnp.mean(v, axis=1) for k, v in mf.items()}
        else:
            stats = {k: block_average(v, n_blocks) for k, v in mf.items()}
            series = mf
        return (
            {k: v[0] for k, v in stats.items()},
            {k: v[1] for k, v in stats.items()},
            series,
            jnp.sum(final.guard_hits),
            jnp.max(final.max_extension2),
        )

    return jax.vmap(one_rate)(init_keys, noise_keys, rates, dts)


def flow_curve(
    key,
    flow: str,
    rates,
    spring,
    *,
    n_dumbbells: int,
    dt,
    n_equilibrate: int,
    n_samples: int,
    sample_every: int = 10,
    n_blocks: int = 32,
    blocks: str = "ensemble",
    dtype=jnp.float64,
    variance_reduction: bool = False,
    common_noise: bool = False,
    noise: str = "gaussian",
) -> FlowCurve:
    """Steady-state material functions at many rates in one jitted, vmapped call.

    Each rate starts from an exact equilibrium ensemble, runs ``n_equilibrate`` steps,
    then ``n_samples * sample_every`` steps observed every ``sample_every`` steps.

    Args:
      key: PRNG key.
      flow: ``shear``, ``planar_elongation``, ``uniaxial_elongation`` or ``equilibrium``.
      rates: ``(R,)`` dimensionless rates De (> 0; for ``equilibrium`` any positive
        placeholder).
      spring: :class:`Hookean` or :class:`FENE`.
      n_dumbbells: ensemble size per rate.
      dt: time step (units lambda_H), scalar or ``(R,)`` (one per rate; the step counts
        are shared, so the simulated time is ``n * dt`` per rate).
      n_equilibrate: steps discarded before averaging (>= 0).
      n_samples, sample_every: averaging window, ``n_samples * sample_every`` steps.
      n_blocks: number of blocks for the error bars (>= 2).
      blocks: ``"ensemble"`` (default): the ensemble is cut into ``n_blocks`` groups of
        ``n_dumbbells / n_blocks`` dumbbells whose time averages are independent
        (dilute dumbbells do not interact), so the standard error needs no
        correlation-time assumption; ``"time"``: the ensemble-mean time series is cut
        into ``n_blocks`` blocks, valid when a block is much longer than the
        correlation time (about 2 lambda_H at rest, for variance-reduced quantities).
      dtype: float32 or float64.
      variance_reduction: subtract a same-noise twin ensemble at rest (module doc).
      common_noise: use the same initial ensemble and noise for every rate (smooth
        curves, correlated errors); default independent per rate.
      noise: ``"gaussian"`` or ``"three_point"`` (weak order 2, 3-4x cheaper; see
        :func:`jaxdpd.brownian.dynamics.wiener_increments`).

    Returns:
      :class:`FlowCurve` (NumPy arrays).
    """
    check_flow(flow)
    dtype = float_dtype(dtype)
    check_spring(spring)
    check_noise(noise)
    rates_np = np.atleast_1d(np.asarray(rates, dtype=np.float64))
    if rates_np.ndim != 1:
        raise ValueError(f"rates must be a scalar or 1-D, got shape {rates_np.shape}")
    check_positive("rates", rates_np)
    check_positive("dt", dt)
    dts_np = np.broadcast_to(np.asarray(dt, dtype=np.float64), rates_np.shape)
    n_dumbbells = check_count("n_dumbbells", n_dumbbells)
    n_equilibrate = check_count("n_equilibrate", n_equilibrate, 0)
    n_samples = check_count("n_samples", n_samples)
    sample_every = check_count("sample_every", sample_every)
    n_blocks = check_count("n_blocks", n_blocks, 2)
    if blocks not in ("ensemble", "time"):
        raise ValueError(f"blocks must be 'ensemble' or 'time', got {blocks!r}")
    if blocks == "ensemble" and n_dumbbells % n_blocks:
        raise ValueError(
            f"n_dumbbells={n_dumbbells} must be a multiple of n_blocks={n_blocks} "
            "for blocks='ensemble'"
        )
    if blocks == "time" and n_samples < n_blocks:
        raise ValueError(f"n_samples={n_samples} must be >= n_blocks={n_blocks}")
    spring_c = jax.tree.map(lambda x: jnp.asarray(x, dtype=dtype), spring)
    means, sems, series, guard, ext2 = _flow_curve_core(
        key,
        jnp.asarray(rates_np, dtype=dtype),
        jnp.asarray(dts_np, dtype=dtype),
        spring_c,
        flow=flow,
        n_dumbbells=n_dumbbells,
        n_equilibrate=n_equilibrate,
        n_samples=n_samples,
        sample_every=sample_every,
        n_blocks=n_blocks,
        blocks=blocks,
        dtype=np.dtype(dtype).name,
        variance_reduction=bool(variance_reduction),
        common_noise=bool(common_noise),
        noise=noise,
    )
    to_np = lambda d: {k: np.asarray(v) for k, v in d.items()}  # noqa: E731
    return FlowCurve(
        flow=flow,
        rates=rates_np,
        values=to_np(means),
        errors=to_np(sems),
        series=to_np(series),
        blocks=blocks,
        guard_hits=np.asarray(guard),
        max_extension2=np.asarray(ext2),
        dt=np.array(dts_np),
        t_average=np.array(dts_np) * n_samples * sample_every,
    )
