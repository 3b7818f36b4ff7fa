"""Pathwise derivatives through a whole DPD run, with a divergence check.

The pathwise (forward-mode) derivative of a time average with respect to a traced
model parameter θ (jaxdpd.engine.parameters) differentiates the trajectory itself:
x(t; θ) and its tangent ∂x/∂θ are advanced together (`jax.jvp` through the
`lax.scan` of the run, so memory does not grow with the number of steps).

For a chaotic many-particle system the tangent grows like exp(λ_max t) with the
largest Lyapunov exponent λ_max > 0 (a DPD fluid at ρ = 3, a = 25 is chaotic):
after a few time units the pathwise derivative of a long-time average is dominated
by that growth and becomes useless, and after long runs it overflows.  This is a
property of the estimator, not a bug (e.g. Lea, Allen & Haine, Nature 405, 2000,
for climate sensitivities; Ni & Wang, J. Comput. Phys. 2017).  For equilibrium
averages the fluctuation (likelihood-ratio) estimator
d⟨A⟩/dθ = −Cov(A, ∂U/∂θ)/k_BT (`jaxdpd.studies.dpd_fit.measure_sensitivity`) has no such
growth.  `pathwise_derivative` therefore measures the growth of the tangent and
warns, naming that estimator, when the derivative cannot be trusted.
"""

import warnings

import jax
import jax.numpy as jnp

from jaxdpd.engine import errors
from jaxdpd.engine.parameters import with_parameters
from jaxdpd.run import driver

# Largest tolerated growth of the position tangent, |∂x/∂θ| at the end over its
# largest value in the first chunk: beyond it, exponential divergence has taken over.
MAX_TANGENT_GROWTH = 1e3


class PathwiseDerivativeWarning(UserWarning):
    """The pathwise derivative of a run diverged or overflowed."""


def pathwise_derivative(simulation, state, steps: int, parameter: dict, series: str):
    """d⟨A⟩/dθ of the run average of a per-step series A by forward-mode
    differentiation of the trajectory.

    Args:
        simulation: a built Simulation (jaxdpd.engine.build.build).
        state: its starting state (equilibrated).
        steps: steps to run (≥ 2; the first tenth is the reference for the tangent
            growth check).
        parameter: the traced parameter, e.g. {"bond": {"dumbbell": "spring_constant"}}
            (one leaf naming its field).
        series: the per-step sample to average, e.g. "dumbbell/bond_length_sq".
    Returns:
        (⟨A⟩, d⟨A⟩/dθ, tangent growth) as Python floats.  A `PathwiseDerivativeWarning`
        is issued when the derivative is not finite or the position tangent grew by
        more than MAX_TANGENT_GROWTH (then use the fluctuation estimator,
        jaxdpd.studies.dpd_fit.measure_sensitivity).
    Raises:
        ValueError: steps < 2, or `parameter` does not name one traced parameter.
        SimulationError: the run itself raised an error flag.
    """
    if steps < 2:
        raise ValueError(f"steps = {steps}: need at least 2 steps")
    path = _leaf_path(parameter)
    value = _get(state.parameters, path, parameter)
    warm_up = max(1, steps // 10)

    def run(theta):
        start = with_parameters(state, _nested(path, theta))
        middle, early = driver._scan_chunk(simulation.step_fn, start, warm_up)
        final, late = driver._scan_chunk(simulation.step_fn, middle, steps - warm_up)
        average = jnp.concatenate([early[series], late[series]]).mean()
        return average, middle.positions, final.positions, final.flags

    (average, _, _, flags), (slope, early_tangent, late_tangent, _) = jax.jvp(
        run, (value,), (jnp.ones_like(value),)
    )
    if int(flags):
        raise errors.SimulationError(f"pathwise run: {errors.describe(int(flags))}")
    early_size = float(jnp.max(jnp.abs(early_tangent)))
    late_size = float(jnp.max(jnp.abs(late_tangent)))
    growth = late_size / early_size if early_size > 0 else float("inf")
    slope = float(slope)
    if not (jnp.isfinite(slope) and growth <= MAX_TANGENT_GROWTH):
        warnings.warn(
            f"pathwise derivative through {steps} steps diverged (position tangent grew "
            f"{growth:.3g}×, derivative {slope:.3g}): the dynamics is chaotic, so the "
            "tangent grows exponentially; use the fluctuation estimator "
            "jaxdpd.studies.dpd_fit.measure_sensitivity for equilibrium averages",
            PathwiseDerivativeWarning,
            stacklevel=2,
        )
    return float(average), slope, growth


def _leaf_path(parameter: dict) -> tuple[str, ...]:
    path = []
    node = parameter
    while isinstance(node, dict):
        if len(node) != 1:
            raise ValueError(f"parameter = {parameter!r}: name exactly one traced parameter")
        ((key, node),) = node.items()
        path.append(key)
    if not isinstance(node, str):
        raise ValueError(f"parameter = {parameter!r}: the leaf must be the field name")
    return (*path, node)


def _get(tree: dict, path, parameter):
    node = tree
    for key in path:
        if not isinstance(node, dict) or key not in node:
            raise ValueError(
                f"parameter = {parameter!r}: not a traced parameter of this scene "
                f"(traced: {jax.tree_util.tree_structure(tree)})"
            )
        node = node[key]
    return node


def _nested(path, value) -> dict:
    for key in reversed(path):
        value = {key: value}
    return value
