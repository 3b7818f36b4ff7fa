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
shear                  ``psi2`` Psi_2                          -(tau_yy - tau_zz) / De^2   BAH ch. 3
planar_elongation      ``elongational_viscosity_1`` eta_bar_1  -(tau_zz - tau_xx) / De thesis 3.25
planar_elongation      ``elongational_viscosity_2`` eta_bar_2  -(tau_yy - tau_xx) / De thesis 3.26
uniaxial_elongation    ``elongational_viscosity`` eta_bar      -(tau_xx - tau_yy) / De   BAH ch. 3
all                    ``q2`` <Q^2>; ``extension2`` <Q^2>/Q_0^2 (thesis Fig. 4-10);
                       ``extension`` <|Q|>/Q_0 (NaN for Hookean springs)
=====================  ======================================  ============== =========

Planar elongation stretches along z and compresses along x (y neutral), as in the DPD
flows (:mod:`jaxdpd.brownian.flows`, docs/conventions.md).

In the linear (Newtonian) limit the polymer stress is ``-eta_p0 (kappa + kappa^T)``, so
the Trouton ratios are ``eta_bar_1/eta_p0 = 4`` (planar) and ``eta_bar/eta_p0 = 3``
(uniaxial).

Error bars are block averages (:func:`jaxdpd.analysis.statistics.block_average`) of the time
series of ensemble means; every material function is linear in the ensemble mean of
``f Q Q`` at one time, so its per-sample series is block-averaged directly (the
extension uses ``<|Q|>``, also linear).

**Variance reduction** (``variance_reduction=True``): a twin ensemble at rest with the
same initial connectors and the same Wiener increments is run alongside, and its
stress is subtracted as a control variate (Bonvin & Picasso, J. Non-Newtonian Fluid
Mech. 84, 191 (1999); Öttinger, *Stochastic Processes in Polymeric Fluids*, ch. 4).  The
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

from jaxdpd.analysis.statistics import block_average
from jaxdpd.brownian._checks import check_count, check_positive, float_dtype
from jaxdpd.brownian.dynamics import check_noise, simulate, state_from_connectors
from jaxdpd.brownian.flows import check_flow, velocity_gradient
from jaxdpd.brownian.springs import check_spring

__all__ = [
    "kramers_tensor",
    "ensemble_moments",
    "kramers_stress",
    "material_functions",
    "MATERIAL_FUNCTIONS",
    "FlowCurve",
    "flow_curve",
    "flow_curves",
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
        d["elongational_viscosity_1"] = (fqq[..., 2, 2] - fqq[..., 0, 0]) / rate
        d["elongational_viscosity_2"] = (fqq[..., 1, 1] - fqq[..., 0, 0]) / rate
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

    def select(self, which) -> FlowCurve:
        """The sub-curve at the rates picked by ``which`` (boolean mask or indices)."""
        idx = np.arange(self.rates.shape[0])[which]
        pick = lambda d: {k: v[idx] for k, v in d.items()}  # noqa: E731
        return dataclasses.replace(
            self,
            rates=self.rates[idx],
            values=pick(self.values),
            errors=pick(self.errors),
            series=pick(self.series),
            guard_hits=self.guard_hits[idx],
            max_extension2=self.max_extension2[idx],
            dt=self.dt[idx],
            t_average=self.t_average[idx],
        )


@functools.partial(jax.jit, static_argnames=("n_dumbbells", "dtype"))
def _equilibrium_connectors(key, spring, n_dumbbells, dtype):
    return spring.sample_equilibrium(key, n_dumbbells, dtype)


@functools.partial(
    jax.jit,
    static_argnames=(
        "n_equilibrate", "n_samples", "sample_every", "n_groups", "variance_reduction", "noise",
    ),
)  # fmt: skip
def _steady_state_core(
    noise_keys, connectors, kappas, dts, spring, *, n_equilibrate, n_samples, sample_every,
    n_groups, variance_reduction, noise,
):  # fmt: skip
    """Per rate: group time-averages and ensemble-mean series of <fQQ>, <Q^2>, <|Q|>.

    The flow enters only through ``kappas`` (R, 3, 3), so one compiled program serves
    every flow with the same ensemble size, step counts and options.
    """

    def one_rate(k_n, q0, kappa, dt):
        state0 = state_from_connectors(q0, spring)
        kaps = jnp.stack([kappa, jnp.zeros_like(kappa)]) if variance_reduction else kappa[None]

        n_skip = -(-n_equilibrate // sample_every)  # equilibration, in whole chunks

        def run(kap):
            # one scan for equilibration and averaging: the step is compiled once
            final, samples = simulate(
                k_n, state0, kap, spring, dt, n_samples=n_skip + n_samples,
                sample_every=sample_every, noise=noise,
                observe=lambda c, s: ensemble_moments(c, s, n_groups),
            )  # fmt: skip
            return final, jax.tree.map(lambda x: x[n_skip:], samples)

        final, samples = jax.vmap(run)(kaps)
        samples = jax.tree.map(lambda x: x[0], samples) | (
            {"fqq": samples["fqq"][0] - samples["fqq"][1]} if variance_reduction else {}
        )
        # samples[name]: (S, G, ...) or (S, ...) when n_groups == 1
        groups = jax.tree.map(lambda x: jnp.mean(x, axis=0), samples)
        series = samples if n_groups == 1 else jax.tree.map(lambda x: jnp.mean(x, 1), samples)
        return groups, series, jnp.sum(final.guard_hits), jnp.max(final.max_extension2)

    return jax.vmap(one_rate)(noise_keys, connectors, kappas, dts)


def flow_curves(
    key,
    flows: dict,
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
) -> dict:
    """Steady-state material functions of several flows and rates in ONE jitted call.

    The velocity gradients of every (flow, rate) pair are stacked and the whole set is
    simulated by one vmapped, jitted program (:func:`flow_curve` is the one-flow case).
    Each rate starts from an exact equilibrium ensemble, runs ``n_equilibrate`` steps,
    then ``n_samples * sample_every`` steps observed every ``sample_every`` steps.

    Args:
      key: PRNG key.
      flows: dict flow name -> rates, e.g. ``{"shear": [0.1, 1, 10],
        "planar_elongation": [0.1, 1]}``; rates are dimensionless ``De`` (> 0; for
        ``equilibrium`` any positive placeholder).
      spring: :class:`Hookean` or :class:`FENE`.
      n_dumbbells: ensemble size per rate.
      dt: time step (units lambda_H): a scalar, or a dict flow name -> scalar or array
        (one per rate; the step counts are shared, so the simulated time is ``n dt``).
      n_equilibrate: steps discarded before averaging (>= 0; rounded up to a multiple
        of ``sample_every``, since equilibration and averaging share one scan).
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
      noise: ``"gaussian"`` or ``"three_point"`` (weak order 2, cheaper; see
        :func:`jaxdpd.brownian.dynamics.wiener_increments`).

    Returns:
      dict flow name -> :class:`FlowCurve` (NumPy arrays).
    """
    if not isinstance(flows, dict) or not flows:
        raise ValueError(f"flows must be a non-empty dict flow name -> rates, got {flows!r}")
    dtype = float_dtype(dtype)
    check_spring(spring)
    check_noise(noise)
    rates_of, dts_of = {}, {}
    for flow, rates in flows.items():
        check_flow(flow)
        r = np.atleast_1d(np.asarray(rates, dtype=np.float64))
        if r.ndim != 1:
            raise ValueError(f"rates must be a scalar or 1-D, got shape {r.shape} for {flow}")
        check_positive("rates", r)
        d = dt[flow] if isinstance(dt, dict) else dt
        check_positive("dt", d)
        rates_of[flow] = r
        dts_of[flow] = np.broadcast_to(np.asarray(d, dtype=np.float64), r.shape)
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
    all_rates = np.concatenate(list(rates_of.values()))
    all_dts = np.concatenate(list(dts_of.values()))
    n_total = all_rates.shape[0]
    k_init, k_noise = jax.random.split(key)
    if common_noise:
        init_keys, noise_keys = [k_init] * n_total, jnp.stack([k_noise] * n_total)
    else:
        init_keys = list(jax.random.split(k_init, n_total))
        noise_keys = jax.random.split(k_noise, n_total)
    connectors = jnp.stack(
        [_equilibrium_connectors(k, spring_c, n_dumbbells, dtype.name) for k in init_keys]
    )
    kappas = jnp.concatenate([velocity_gradient(f, r, dtype) for f, r in rates_of.items()])
    n_groups = n_blocks if blocks == "ensemble" else 1
    groups, series, guard, ext2 = _steady_state_core(
        noise_keys,
        connectors,
        kappas,
        jnp.asarray(all_dts, dtype=dtype),
        spring_c,
        n_equilibrate=n_equilibrate,
        n_samples=n_samples,
        sample_every=sample_every,
        n_groups=n_groups,
        variance_reduction=bool(variance_reduction),
        noise=noise,
    )
    # Material functions are linear in the means, so they are formed per group (or per
    # sample) and then block-averaged.
    out, start = {}, 0
    for flow, rates in rates_of.items():
        sl = slice(start, start + rates.shape[0])
        start = sl.stop
        rate = jnp.asarray(rates, dtype=dtype)[:, None]
        pick = lambda m, sl=sl: jax.tree.map(lambda x: x[sl], m)  # noqa: E731

        def mf_of(m, rate=rate, flow=flow):
            return material_functions(flow, rate, m["fqq"], m["q2"], m["q"], spring=spring_c)

        series_mf = mf_of(pick(series))  # (R, S)
        source = mf_of(pick(groups)) if blocks == "ensemble" else series_mf
        stats = {k: block_average(v, n_blocks, axis=1) for k, v in source.items()}
        to_np = lambda d: {k: np.asarray(v) for k, v in d.items()}  # noqa: E731
        out[flow] = FlowCurve(
            flow=flow,
            rates=rates,
            values=to_np({k: v[0] for k, v in stats.items()}),
            errors=to_np({k: v[1] for k, v in stats.items()}),
            series=to_np(series_mf),
            blocks=blocks,
            guard_hits=np.asarray(guard[sl]),
            max_extension2=np.asarray(ext2[sl]),
            dt=np.array(dts_of[flow]),
            t_average=np.array(dts_of[flow]) * n_samples * sample_every,
        )
    return out


def flow_curve(key, flow: str, rates, spring, **kwargs) -> FlowCurve:
    """Steady-state material functions of one flow at many rates (one jitted call).

    ``flow_curve(key, flow, rates, spring, **kw)`` is
    ``flow_curves(key, {flow: rates}, spring, **kw)[flow]``; see :func:`flow_curves`
    for the keyword arguments (``n_dumbbells``, ``dt``, ``n_equilibrate``,
    ``n_samples``, ``sample_every``, ``n_blocks``, ``blocks``, ``dtype``,
    ``variance_reduction``, ``common_noise``, ``noise``).

    Returns:
      :class:`FlowCurve` (NumPy arrays).
    """
    check_flow(flow)
    if isinstance(kwargs.get("dt"), dict):
        raise ValueError("dt must be a scalar or an array of one dt per rate for flow_curve")
    return flow_curves(key, {flow: rates}, spring, **kwargs)[flow]
