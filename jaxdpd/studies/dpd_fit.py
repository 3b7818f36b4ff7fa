"""Fitting DPD model parameters by gradient, through the DPD engine.

The bond constants are traced inputs of the compiled step (`SimState.parameters`,
jaxdpd.engine.parameters), so one compilation serves every value a fit visits, and an
ensemble may run several values side by side.

**Which derivative.**  A DPD trajectory is chaotic: the pathwise derivative
d r(t)/dθ of a trajectory grows like exp(λ_max t), so differentiating a long time
average through the integrator (jax.grad/jvp of the run, as jaxdpd.brownian.fit does
for dumbbells, whose dynamics contract) gives an estimate whose variance explodes
with the run length.  For an *equilibrium* average no trajectory derivative is
needed: DPD samples the canonical distribution ∝ exp(−U/k_BT) (Español & Warren,
Europhys. Lett. 30, 191 (1995): the fluctuation–dissipation pair of dissipative and
random forces leaves the Gibbs distribution stationary), so for an observable A
and a parameter θ of the potential energy U,

    d⟨A⟩/dθ = ⟨∂A/∂θ⟩ − (⟨A ∂U/∂θ⟩ − ⟨A⟩⟨∂U/∂θ⟩)/k_BT

(differentiate ⟨A⟩ = ∫ A e^{−U/k_BT} / ∫ e^{−U/k_BT} under the integral: the
derivative of the Boltzmann factor gives the covariance).  It is
exact, needs one run at θ and the per-step ∂U/∂θ (here by forward-mode autodiff of
the bond law), and its error bar is a block average like any other.  It is the
equilibrium form of the likelihood-ratio estimator that jaxdpd.brownian.fit uses for
non-smooth observables; the Boltzmann weight replaces the path weight.  Its
limitation: equilibrium averages only (for steady shear the stationary
distribution is not known in closed form), and the time-step error of the
integrator makes the sampled distribution slightly non-canonical (checked against
central finite differences in the tests).

Two estimators of the covariance, from the per-step samples of
`sensitivity_simulation` (A = ⟨a(Q²)⟩ over the springs of one species):

- `canonical_sensitivity`: the formula above with U_θ = Σ_springs ∂u/∂θ; exact.
- `independent_spring_sensitivity`: keeps only the covariance of each spring's a
  with its own ∂u/∂θ, dropping spring–spring cross terms (exact for independent
  springs, e.g. dilute dumbbells); its variance is smaller by about the number of
  springs, its bias is the cross-spring covariance.

**Fitting** (`fit_bond_parameter`): an optax optimiser minimises the loss
½ ((A(θ) − A*)/A*)² over log θ.  Each iteration continues the trajectory at the new
θ (`equilibration` steps discarded, `steps` averaged) and the gradient is
(A − A*)/A*² · θ dA/dθ from the canonical estimator.  By default the update is a
Gauss–Newton step (gradient divided by the curvature (θ dA/dθ / A*)², the optax
transformation `scale_by_inverse_curvature`, followed by `optax.sgd`): a Newton
step for the root A(θ) = A*, so each iterate's error is the last measurement's
error of A over the slope; the estimate is the mean of the iterates of the second
half (Polyak–Ruppert averaging), its error their spread.  The root does not depend
on the accuracy of the derivative, only on A: the fit lands on A(θ) = A* however
rough dA/dθ is.
"""

import dataclasses
import math

import jax
import jax.numpy as jnp
import numpy as np
import optax

from jaxdpd.analysis.conformation import bond_vectors
from jaxdpd.analysis.statistics import block_average
from jaxdpd.engine.parameters import with_parameters
from jaxdpd.geometry.chain_topology import chain_coordinates
from jaxdpd.run import driver
from jaxdpd.run.series import collect

SAMPLE_PREFIX = "sensitivity/"


def spring_length_squared(q_sq):
    """The default per-spring observable a(Q²) = Q²."""
    return q_sq


def sensitivity_simulation(simulation, species: str, parameter: str, spring_observable=None):
    """The simulation with three more per-step samples for parameter sensitivities.

    Build it once and reuse it (its step function is the key of the compiled
    chunks).

    Args:
        simulation: from jaxdpd.engine.build.build, with [[polymers]].
        species: the chained species whose bond parameter is studied.
        parameter: the parameter of its bond law (e.g. "spring_constant").
        spring_observable: a(Q²) per spring, elementwise (default Q²).
    Returns:
        A Simulation whose step also records, over the block's S springs:
            "sensitivity/observable"           Ā = (1/S) Σ_k a_k
            "sensitivity/energy_derivative"    U_θ = Σ_k ∂u_k/∂θ
            "sensitivity/product"              (1/S) Σ_k a_k ∂u_k/∂θ
    Raises:
        ValueError: unknown species or parameter (naming the valid ones).
    """
    blocks = {block.species: block for block in simulation.blocks}
    if species not in blocks:
        raise ValueError(f"species = {species!r}: chained species are {sorted(blocks)}")
    block = blocks[species]
    if parameter not in block.law.parameters:
        raise ValueError(
            f"parameter = {parameter!r}: the {block.law.name!r} law has "
            f"{sorted(block.law.parameters)}"
        )
    observable = spring_observable or spring_length_squared
    box, step = simulation.box, simulation.step_fn

    def step_fn(state):
        state, samples = step(state)
        chains = chain_coordinates(box.bind(state.box_state), state.positions, block, state.image)
        q_sq = jnp.sum(bond_vectors(chains) ** 2, axis=-1)
        values = state.parameters["bond"][species]

        def spring_energies(value):
            return block.law.with_parameters({**values, parameter: value}).energy(q_sq)

        value = values[parameter]
        _, derivative = jax.jvp(spring_energies, (value,), (jnp.ones_like(value),))
        a = observable(q_sq)
        samples[f"{SAMPLE_PREFIX}observable"] = jnp.mean(a)
        samples[f"{SAMPLE_PREFIX}energy_derivative"] = jnp.sum(derivative)
        samples[f"{SAMPLE_PREFIX}product"] = jnp.mean(a * derivative)
        return state, samples

    return dataclasses.replace(simulation, step_fn=step_fn)


def _trimmed(series, n_blocks: int):
    """The last n_blocks·⌊T/n_blocks⌋ samples (those block_average uses), (..., T)."""
    x = jnp.asarray(series)
    used = n_blocks * (x.shape[-1] // n_blocks)
    return x[..., x.shape[-1] - used :]


def canonical_sensitivity(observable, energy_derivative, kT: float, n_blocks: int = 20):
    """d⟨A⟩/dθ = −(⟨A U_θ⟩ − ⟨A⟩⟨U_θ⟩)/k_BT (module docstring), A without explicit θ.

    Args:
        observable: (..., T) series of A.
        energy_derivative: (..., T) series of ∂U/∂θ, sampled with A.
        kT: k_BT.
        n_blocks: blocks of the time series for the error.
    Returns:
        (derivative, standard error), arrays (...): the error is the block average
        of (A − Ā)(U_θ − Ū_θ), whose mean is the covariance.
    """
    a = _trimmed(observable, n_blocks)
    u = _trimmed(energy_derivative, n_blocks)
    products = (a - a.mean(axis=-1, keepdims=True)) * (u - u.mean(axis=-1, keepdims=True))
    covariance, error = block_average(products, n_blocks=n_blocks, axis=-1)
    return -covariance / kT, error / kT


def independent_spring_sensitivity(
    observable, energy_derivative, product, n_springs: int, kT: float, n_blocks: int = 20
):
    """d⟨A⟩/dθ with the spring–spring cross covariances dropped (module docstring).

    With Ā_t, U_t and P_t = (1/S) Σ_k a_k u_k per step: −(⟨P⟩ − ⟨Ā⟩⟨U⟩/S)/k_BT.

    Args:
        observable, energy_derivative, product: (..., T) series of Ā, U_θ and P
            ("sensitivity/..." samples).
        n_springs: S.
        kT: k_BT.
        n_blocks: blocks of the time series for the error.
    Returns:
        (derivative, standard error), arrays (...); the error is the block average
        of the linearised series P − ⟨Ā⟩ U/S − ⟨U⟩ Ā/S.
    """
    a = _trimmed(observable, n_blocks)
    u = _trimmed(energy_derivative, n_blocks) / n_springs
    p = _trimmed(product, n_blocks)
    a_mean = a.mean(axis=-1, keepdims=True)
    u_mean = u.mean(axis=-1, keepdims=True)
    linear = p - a_mean * u - u_mean * a + a_mean * u_mean
    covariance, error = block_average(linear, n_blocks=n_blocks, axis=-1)
    return -covariance / kT, error / kT


@dataclasses.dataclass(frozen=True)
class Sensitivity:
    """An equilibrium average and its parameter derivative (NumPy; shapes (...)
    for a batch of replicas, else scalars).

    Attributes:
        value, value_error: ⟨A⟩ and its standard error.
        derivative, derivative_error: d⟨A⟩/dθ (canonical estimator) and its error.
        independent, independent_error: the independent-spring estimate.
    """

    value: np.ndarray
    value_error: np.ndarray
    derivative: np.ndarray
    derivative_error: np.ndarray
    independent: np.ndarray
    independent_error: np.ndarray


def measure_sensitivity(
    sensitivity, state, steps: int, chunk: int, kT: float, n_springs: int, n_blocks: int = 20
):
    """Run a sensitivity simulation and estimate ⟨A⟩ and d⟨A⟩/dθ.

    Args:
        sensitivity: from `sensitivity_simulation`.
        state: a single state or a batch (jaxdpd.run.ensemble), equilibrated.
        steps, chunk: averaged steps and steps per jitted chunk.
        kT: k_BT.
        n_springs: springs of the species (for the independent-spring estimate).
        n_blocks: blocks of the time series.
    Returns:
        (final state, Sensitivity).
    """
    state, series = collect(sensitivity, state, steps, chunk)

    def along_time_last(name):
        values = jnp.asarray(series[f"{SAMPLE_PREFIX}{name}"])
        return jnp.moveaxis(values, 1, -1) if values.ndim == 2 else values

    a = along_time_last("observable")
    u = along_time_last("energy_derivative")
    p = along_time_last("product")
    value, value_error = block_average(a, n_blocks=n_blocks, axis=-1)
    derivative = canonical_sensitivity(a, u, kT, n_blocks)
    independent = independent_spring_sensitivity(a, u, p, n_springs, kT, n_blocks)
    estimates = (value, value_error, *derivative, *independent)
    return state, Sensitivity(*(np.asarray(x) for x in estimates))


def scale_by_inverse_curvature() -> optax.GradientTransformationExtraArgs:
    """optax transformation dividing the gradient by `curvature` (an extra argument
    of `update`), e.g. the Gauss–Newton curvature J² of a least-squares loss: with
    `optax.sgd(1.0)` after it, the update is a Newton step for the residual's root."""

    def init(params):
        del params
        return optax.EmptyState()

    def update(updates, state, params=None, *, curvature, **extra):
        del params, extra
        return jax.tree.map(lambda g: g / curvature, updates), state

    return optax.GradientTransformationExtraArgs(init, update)


@dataclasses.dataclass(frozen=True)
class BondFit:
    """Outcome of `fit_bond_parameter` (NumPy arrays over iterations).

    Attributes:
        estimate, estimate_error: θ from the mean of the second half of the
            iterates, and the standard error of that mean.
        parameters: θ at which each iteration measured.
        values, value_errors: ⟨A⟩ measured there.
        derivatives, derivative_errors: d⟨A⟩/dθ (canonical estimator) there.
        losses: ½ ((⟨A⟩ − A*)/A*)² there.
        state: the final state.
    """

    estimate: float
    estimate_error: float
    parameters: np.ndarray
    values: np.ndarray
    value_errors: np.ndarray
    derivatives: np.ndarray
    derivative_errors: np.ndarray
    losses: np.ndarray
    state: object


def fit_bond_parameter(
    simulation,
    state,
    *,
    species: str,
    parameter: str,
    target: float,
    start: float,
    iterations: int,
    steps: int,
    equilibration: int,
    chunk: int,
    optimizer=None,
    n_blocks: int = 20,
    sensitivity=None,
):
    """Fit one bond parameter θ so that the equilibrium ⟨A⟩ (default ⟨Q²⟩) of a
    species' springs equals `target` (module docstring).

    Args:
        simulation: from jaxdpd.engine.build.build (the scene's value of θ is unused).
        state: a start state (e.g. equilibrated at some θ).
        species, parameter: which bond parameter (e.g. "dumbbell", "spring_constant").
        target: A*, the value to reproduce (> 0).
        start: θ to start from (> 0; θ is fitted on a log scale).
        iterations: optimiser iterations (≥ 2), one run of equilibration + steps each.
        steps: averaged steps per iteration (≥ 2 n_blocks).
        equilibration: steps discarded after each change of θ.
        chunk: steps per jitted chunk.
        optimizer: an optax transformation of log θ; its `update` receives the extra
            argument `curvature` = (θ dA/dθ / A*)².  Default: Gauss–Newton,
            `optax.chain(scale_by_inverse_curvature(), optax.sgd(1.0))`.
        n_blocks: blocks of each iteration's time series.
        sensitivity: a prebuilt `sensitivity_simulation(simulation, species,
            parameter)` to reuse its compiled chunks (optional).
    Returns:
        BondFit.
    """
    if not (target > 0 and start > 0):
        raise ValueError(f"target = {target!r} and start = {start!r} must be > 0")
    if iterations < 2 or steps < 2 * n_blocks:
        raise ValueError(
            f"iterations = {iterations} must be ≥ 2 and steps = {steps} ≥ 2 n_blocks = "
            f"{2 * n_blocks}"
        )
    sensitivity = sensitivity or sensitivity_simulation(simulation, species, parameter)
    block = next(b for b in simulation.blocks if b.species == species)
    n_springs = block.n_chains * (block.beads - 1)
    kT = simulation.scene.solvent.kT
    if optimizer is None:
        optimizer = optax.chain(scale_by_inverse_curvature(), optax.sgd(1.0))
    log_theta = jnp.asarray(math.log(start), simulation.dtype)
    optimizer_state = optimizer.init(log_theta)
    history = []
    for _ in range(iterations):  # optimiser iterations, each a DPD run
        theta = float(jnp.exp(log_theta))
        state = with_parameters(
            state, {"bond": {species: {parameter: jnp.asarray(theta, simulation.dtype)}}}
        )
        state = driver.run(sensitivity, state, equilibration, chunk)
        state, result = measure_sensitivity(
            sensitivity, state, steps, chunk, kT, n_springs, n_blocks
        )
        residual = (float(result.value) - target) / target
        slope = theta * float(result.derivative) / target  # d(A/A*)/d log θ
        gradient = jnp.asarray(residual * slope, simulation.dtype)
        updates, optimizer_state = optimizer.update(
            gradient, optimizer_state, log_theta, curvature=slope * slope
        )
        log_theta = optax.apply_updates(log_theta, updates)
        history.append((theta, result, 0.5 * residual * residual))
    thetas = np.array([h[0] for h in history])
    tail = thetas[len(thetas) // 2 :]
    return BondFit(
        estimate=float(tail.mean()),
        estimate_error=float(tail.std(ddof=1) / math.sqrt(len(tail))),
        parameters=thetas,
        values=np.array([float(h[1].value) for h in history]),
        value_errors=np.array([float(h[1].value_error) for h in history]),
        derivatives=np.array([float(h[1].derivative) for h in history]),
        derivative_errors=np.array([float(h[1].derivative_error) for h in history]),
        losses=np.array([h[2] for h in history]),
        state=state,
    )
