"""Hookean and FENE (Warner) springs of dumbbells: the bond laws in dumbbell units.

Units (Clarke thesis eq. 4.10): length ``sqrt(k_B T / H)``, time ``lambda_H = zeta/(4H)``.
In them the spring constant is H = 1 and a spring is written as ``F_hat(Q) = f(Q^2) Q``
with the *force factor*

    Hookean (eq. 4.1):   f = 1
    FENE    (eq. 4.2):   f = 1 / (1 - Q^2 / b),     b = H Q_0^2 / (k_B T)   (eq. 4.5)

so that ``Q_hat_0^2 = b``.  The force factor and the energy are those of the DPD chains'
bond laws (:data:`jaxdpd.forces.bonds.HOOKEAN`, :data:`jaxdpd.forces.bonds.FENE`)
with H = 1 and Q_0 = sqrt(b): one definition of each law.  The classes here add what
the Brownian integrator needs of a spring.  Springs are pytrees (``b`` is a leaf), so
they can be vmapped over and differentiated with respect to.

Each spring also solves the implicit half-step of the semi-implicit integrator
(:mod:`jaxdpd.brownian.dynamics`): given ``R = |rhs| >= 0`` and ``h = dt/4``, find the
length ``l`` with

    l * (1 + h f(l^2)) = R.                                             (*)

For FENE, (*) is the cubic ``l^3 - R l^2 - b (1 + h) l + b R = 0`` (Öttinger 1996,
*Stochastic Processes in Polymeric Fluids*, ch. 4; Somasi et al., J. Non-Newtonian
Fluid Mech. 108, 227 (2002)), whose left side ``g(l) = l (1 + h/(1 - l^2/b))``
rises monotonically from 0 to infinity on ``[0, sqrt(b))``: there is exactly one root
there, for any ``R`` and any ``h > 0``.  So the new length is always below ``Q_0``.
"""

from __future__ import annotations

import dataclasses

import jax
import jax.numpy as jnp

from jaxdpd.brownian._checks import check_positive, float_dtype
from jaxdpd.forces import bonds
from jaxdpd.trigonometry import trisected_cosine

__all__ = ["Hookean", "FENE", "check_spring"]


@jax.tree_util.register_dataclass
@dataclasses.dataclass(frozen=True)
class Hookean:
    """Hookean spring, ``F_hat = Q_hat`` (thesis eq. 4.1).  No parameter: H sets the units."""

    name = bonds.HOOKEAN.name

    def force_factor(self, q2):
        """``f(Q^2) = 1``: the Hookean law's stiffness at H = 1; shape of ``q2``."""
        return bonds.HOOKEAN.stiffness(q2, spring_constant=1.0)

    def max_q2(self, dtype=jnp.float64):
        """Maximum ``Q^2``: infinite for a Hookean spring."""
        return jnp.asarray(jnp.inf, dtype=float_dtype(dtype))

    def equilibrium_q2(self, dtype=jnp.float64):
        """Exact ``<Q^2>`` at rest: 3 (equipartition; the ``b -> inf`` limit of eq. 4.8)."""
        return jnp.asarray(3.0, dtype=float_dtype(dtype))

    def potential(self, q2):
        """Spring energy in units of k_B T: ``Q^2 / 2``."""
        return bonds.HOOKEAN.energy(q2, spring_constant=1.0)

    def implicit_length(self, r, h):
        """Solve (*) for the Hookean spring: ``l = R / (1 + h)``.

        Returns ``(l, guard)`` with ``guard`` all False (no maximum length).
        """
        return r / (1 + h), jnp.zeros(jnp.shape(r), dtype=jnp.bool_)

    def sample_equilibrium(self, key, n, dtype=jnp.float64):
        """``n`` connectors from the equilibrium Gaussian ``exp(-Q^2/2)``; shape (n, 3)."""
        return jax.random.normal(key, (n, 3), dtype=float_dtype(dtype))

    def initial_connectors(self, key, n, dtype=jnp.float64):
        """Smooth isotropic start: the exact equilibrium Gaussian; shape (n, 3)."""
        return self.sample_equilibrium(key, n, dtype)


@jax.tree_util.register_dataclass
@dataclasses.dataclass(frozen=True)
class FENE:
    """FENE (Warner) spring ``F_hat = Q_hat / (1 - Q_hat^2/b)`` (thesis eq. 4.2, 4.5).

    Attributes:
      b: extensibility parameter ``H Q_0^2 / k_B T`` (> 0; scalar leaf, may be traced).
    """

    b: jax.Array | float

    name = bonds.FENE.name

    def force_factor(self, q2):
        """``f(Q^2) = 1 / (1 - Q^2/b)``: the FENE law's stiffness at H = 1, Q_0 = sqrt(b);
        shape of ``q2``."""
        return bonds.FENE.stiffness(q2, spring_constant=1.0, max_extension=self.b**0.5)

    def max_q2(self, dtype=jnp.float64):
        """Maximum ``Q^2 = Q_0^2 = b``."""
        return jnp.asarray(self.b, dtype=float_dtype(dtype))

    def equilibrium_q2(self, dtype=jnp.float64):
        """Exact ``<Q^2>`` at rest: ``3 b / (b + 5)`` (thesis eq. 4.8)."""
        b = jnp.asarray(self.b, dtype=float_dtype(dtype))
        return 3 * b / (b + 5)

    def potential(self, q2):
        """Spring energy in units of k_B T: ``-(b/2) ln(1 - Q^2/b)``."""
        return bonds.FENE.energy(q2, spring_constant=1.0, max_extension=self.b**0.5)

    def implicit_length(self, r, h):
        """Root of ``l (1 + h/(1 - l^2/b)) = R`` in ``[0, sqrt(b))``.

        The cubic ``p(l) = (l - R)(l^2 - b) - b h l`` has three real roots (one
        negative, one in ``[0, sqrt(b))``, one above); the middle one is computed by
        one of three formulas, chosen by ``rho = R / sqrt(b)`` to avoid cancellation:

        * ``rho < 1e-2``: fixed point ``l <- R / (1 + h f(l^2))`` from ``R/(1+h)``,
          4 iterations (contraction factor ``< 2 h rho^2 < 2e-4``);
        * ``1e-2 <= rho <= 2``: trigonometric (Viète) formula for the middle root;
        * ``rho > 2``: Newton on the gap ``u = 1 - l^2/b``,
          ``K(u) = u (R - l(u)) - h l(u) = 0``, from ``u0 = h sqrt(b)/(R - sqrt(b))``;
          ``K`` is convex and increasing and ``K(u0) >= 0``, so the 4 iterations
          descend monotonically onto the root, and ``l = sqrt(b (1 - u))`` stays
          accurate where ``l`` is within rounding of ``sqrt(b)`` (for ``h`` of order 1
          and above, i.e. absurd steps, ``u0`` is capped and fewer digits result).

        A last Newton step on ``p`` polishes the value, and its derivative is that of
        the implicit function theorem, ``dl/dtheta = -(dp/dtheta)/(dp/dl)``, so
        gradients are exact.  If the exact root is so close to ``sqrt(b)`` that
        rounding would give ``l >= sqrt(b)(1 - 4 eps)``, ``l`` is set to that bound and
        ``guard`` is True for that dumbbell (a diagnostic; it needs ``(R - Q_0) / Q_0``
        of order ``h / eps``, i.e. absurd time steps, and never acts in the tests'
        simulations).

        Args:
          r: ``R >= 0``, any shape.
          h: ``dt / 4`` (scalar or broadcastable).

        Returns:
          ``(l, guard)``: arrays of the shape of ``r``.
        """
        b = self.b
        sqrt_b = jnp.sqrt(b)
        rho = r / sqrt_b
        # small R: fixed point of l = R / (1 + h f(l^2))
        l_small = r / (1 + h)
        for _ in range(4):
            l_small = r / (1 + h / (1 - l_small * l_small / b))
        # moderate R: trigonometric formula, with l = t + R/3 and t^3 + p t + q = 0
        p = -b * (1 + h) - r * r / 3
        q = -2 * r**3 / 27 + b * r * (2 - h) / 3
        m = 2 * jnp.sqrt(-p / 3)
        cos_arg = jnp.clip(3 * q / (p * m), -1, 1)
        l_trig = m * trisected_cosine(cos_arg) + r / 3  # cos(arccos(.)/3 - 2 pi/3)
        # large R: Newton on the gap u = 1 - l^2/b
        big = rho > 2
        r_big = jnp.where(big, r, 3 * sqrt_b)
        # u0 >= root (K(u0) >= 0); capped below 1 for absurd h (then fewer digits, but
        # l stays in (0, sqrt(b)) and finite)
        u_cap = 1 - 1e-4
        u = jnp.minimum(h * sqrt_b / (r_big - sqrt_b), u_cap)
        for _ in range(4):
            s = jnp.sqrt(1 - u)
            length_u = sqrt_b * s
            k = u * (r_big - length_u) - h * length_u
            dk = r_big - length_u + (u + h) * sqrt_b / (2 * s)
            u = jnp.clip(u - k / dk, 0, u_cap)
        l_big = sqrt_b * jnp.sqrt(1 - u)
        root = jnp.where(rho < 1e-2, l_small, jnp.where(big, l_big, l_trig))
        root = jax.lax.stop_gradient(root)
        # One Newton step on p: polishes the value; carries the implicit-function gradient.
        resid = (root - r) * (root * root - b) - b * h * root
        slope = jax.lax.stop_gradient((root * root - b) + 2 * root * (root - r) - b * h)
        length = root - resid / slope
        eps = jnp.finfo(jnp.result_type(length)).eps
        l_max = sqrt_b * (1 - 4 * eps)
        guard = length >= l_max
        length = jnp.where(guard, l_max, jnp.maximum(length, 0))
        return length, guard

    def sample_equilibrium(self, key, n, dtype=jnp.float64):
        """``n`` connectors drawn exactly from ``psi_eq ~ (1 - Q^2/b)^(b/2)``; (n, 3).

        Rejection sampling from the Hookean Gaussian ``exp(-Q^2/2)``: since
        ``ln(1 - x) <= -x``, the ratio ``w = (1 - Q^2/b)^(b/2) exp(Q^2/2)`` is <= 1 and
        a proposal is accepted with probability ``w`` (about 93 % for b = 50).  Exact
        (its mean ``<Q^2> = 3b/(b+5)`` is thesis eq. 4.8), but the accepted set
        changes discontinuously with ``b``: not for differentiation (use
        :meth:`initial_connectors`).
        """
        dt = float_dtype(dtype)
        b = jnp.asarray(self.b, dtype=dt)

        def propose(k):
            k_q, k_u = jax.random.split(k)
            q = jax.random.normal(k_q, (n, 3), dtype=dt)
            q2 = jnp.sum(q * q, axis=-1)
            inside = q2 < b
            x = jnp.where(inside, q2 / b, 0)
            log_w = 0.5 * b * jnp.log1p(-x) + 0.5 * q2
            u = jax.random.uniform(k_u, (n,), dtype=dt)
            return q, inside & (jnp.log(u) < log_w)

        def cond(c):
            return ~jnp.all(c[1])

        def body(c):
            q, done, k = c
            k, k_p = jax.random.split(k)
            q_new, acc = propose(k_p)
            take = acc & ~done
            return jnp.where(take[:, None], q_new, q), done | acc, k

        start = (jnp.zeros((n, 3), dtype=dt), jnp.zeros((n,), dtype=jnp.bool_), key)
        return jax.lax.while_loop(cond, body, start)[0]

    def initial_connectors(self, key, n, dtype=jnp.float64):
        """Smooth, isotropic start strictly inside ``Q_0``; (n, 3).

        ``Q = sqrt(b) tanh(|Z| / sqrt(b)) Z / |Z|`` with ``Z ~ N(0, I)``: close to the
        equilibrium (Gaussian for ``|Z| << sqrt(b)``), exactly isotropic, and a smooth
        function of ``b`` for fixed noise, so runs that start from it can be
        differentiated and finite-differenced with respect to ``b``.  Not the exact
        equilibrium: discard a burn-in of a few ``lambda_H``.
        """
        dt = float_dtype(dtype)
        b = jnp.asarray(self.b, dtype=dt)
        z = jax.random.normal(key, (n, 3), dtype=dt)
        r = jnp.linalg.norm(z, axis=-1, keepdims=True)
        sb = jnp.sqrt(b)
        return z * (sb * jnp.tanh(r / sb) / r)


def check_spring(spring):
    """Raise ValueError for an unknown spring or a concrete ``b`` outside (0, inf)."""
    if isinstance(spring, FENE):
        check_positive("FENE.b", spring.b)
    elif not isinstance(spring, Hookean):
        raise ValueError(f"spring must be Hookean() or FENE(b), got {spring!r}")
    return spring
