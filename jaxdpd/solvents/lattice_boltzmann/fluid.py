"""Fluctuating lattice-Boltzmann fluid: multiple-relaxation-time collision in the
orthogonal D3Q19 mode basis, thermal noise on the non-conserved modes, streaming.

One LB time step τ maps the populations f_i(r) (mass densities, one per lattice
velocity c_i; jaxdpd.solvents.lattice_boltzmann.lattice) to

    f_i(r + c_i a, t + τ) = f*_i(r, t),     f* = E⁻¹ m*,  m = E f,

with the collision acting on the modes m_k (Dünweg, Schiller and Ladd, Phys. Rev. E
76, 036704 (2007), hereafter DSL, §III–IV):

    ρ* = ρ,   j* = j + g                                  (mass, momentum: conserved
                                                          up to the applied impulse g)
    m*_k = m_k^eq + γ_k (m_k − m_k^eq) + ½(1 + γ_k) ψ_k + √(1 − γ_k²) √(μ b_k) ξ_k
                                                          (k = 4 … 18)

in lattice units (velocities in a/τ).  m^eq of the stress modes is that of
Π^eq = ρ c_s² 1 + ρ u u, ψ that of u g + g u (the second-order forcing of Guo, Zheng
and Shi, Phys. Rev. E 65, 046308 (2002), written in modes), and the velocity is
u = (j + g/2)/ρ.  Ghost modes relax fully (γ = 0).  The eigenvalues of the stress
modes set the viscosities (Ahlrichs & Dünweg, J. Chem. Phys. 111, 8225 (1999),
eq. 3 with λ = γ_s − 1; DSL §IV):

    ν   = (a²/τ) c_s² (1 + γ_s) / (2 (1 − γ_s))     shear (kinematic)
    ν_b = (a²/τ) c_s² (1 + γ_b) / (3 (1 − γ_b))     bulk (kinematic, η_b/ρ)

The noise ξ_k (unit variance, independent per node, mode and step; counter-based)
with μ = ρ₀ k_BT τ²/(c_s² a⁵) makes the populations' equilibrium distribution the
product of Gaussians ⟨δf_i δf_j⟩ = μ w_i δ_ij at every node (DSL §IV: fluctuation–
dissipation on the lattice, exact for the linearised dynamics), so that mode k has
variance μ b_k, the momentum density ρ₀ k_BT/a³ per component (equipartition of
ρ₀ a³ u²/2 per node) and the density ρ₀ k_BT/(a³ c_s²) (isothermal ideal-fluid
compressibility).  The amplitude uses the mean density ρ₀ (linearised theory).

The fluid is stored as the deviations f_i − w_i ρ₀ of the populations from the fluid
at rest (the rest state is invariant under collision and streaming, so the step is
the same): in float32 the populations themselves (~w_i ρ₀) would round the small
hydrodynamic signal to ~1e-7 of ρ₀ per step, which biases a shear wave's decay at
the per-cent level; the deviations keep that relative error at round-off.
"""

from dataclasses import dataclass

import jax
import jax.numpy as jnp
import numpy as np

from jaxdpd.solvents.lattice_boltzmann import counter_noise
from jaxdpd.solvents.lattice_boltzmann.lattice import (
    FLUCTUATING_MODES,
    HYDRODYNAMIC_MODES,
    INVERSE_MODE_BASIS,
    MODE_BASIS,
    MODE_NORMS,
    N_VELOCITIES,
    SOUND_SPEED_SQ,
    VELOCITIES,
    WEIGHTS,
)


@dataclass(frozen=True)
class FluidParameters:
    """A lattice-Boltzmann fluid in physical units.

    Attributes:
        nodes: (n_x, n_y, n_z) lattice nodes; the box edges are n_α a.
        grid_spacing: a (length).
        time_step: τ, the LB time step (time).
        density: ρ₀, the mean mass density (mass/length³).
        kinematic_viscosity: ν = η/ρ (length²/time).
        kinematic_bulk_viscosity: ν_b = η_b/ρ (length²/time).
        kT: k_BT of the thermal noise (energy); 0 gives a deterministic fluid.
    """

    nodes: tuple[int, int, int]
    grid_spacing: float
    time_step: float
    density: float
    kinematic_viscosity: float
    kinematic_bulk_viscosity: float
    kT: float

    @property
    def n_nodes(self) -> int:
        """Number of lattice nodes."""
        return int(np.prod(self.nodes))

    @property
    def lattice_speed(self) -> float:
        """a/τ: the physical velocity of a unit lattice velocity."""
        return self.grid_spacing / self.time_step

    @property
    def shear_relaxation(self) -> float:
        """γ_s = (6ν* − 1)/(6ν* + 1), ν* = ν τ/a² (inverse of the module's ν)."""
        nu = self.kinematic_viscosity * self.time_step / self.grid_spacing**2
        return (6 * nu - 1) / (6 * nu + 1)

    @property
    def bulk_relaxation(self) -> float:
        """γ_b = (9ν_b* − 1)/(9ν_b* + 1), ν_b* = ν_b τ/a² (inverse of the module's ν_b)."""
        nu = self.kinematic_bulk_viscosity * self.time_step / self.grid_spacing**2
        return (9 * nu - 1) / (9 * nu + 1)

    @property
    def relaxation_eigenvalues(self) -> np.ndarray:
        """(19,) γ_k: 1 for the conserved modes, γ_b, γ_s ×5, 0 for the ghosts."""
        gammas = np.zeros(N_VELOCITIES)
        gammas[:4] = 1.0
        gammas[4] = self.bulk_relaxation
        gammas[5:10] = self.shear_relaxation
        return gammas

    @property
    def population_variance(self) -> float:
        """μ = ρ₀ k_BT τ²/(c_s² a⁵): equilibrium variance of f_i is μ w_i."""
        a, tau = self.grid_spacing, self.time_step
        return self.density * self.kT * tau * tau / (SOUND_SPEED_SQ * a**5)

    @property
    def mode_variances(self) -> np.ndarray:
        """(19,) equilibrium variance μ b_k of every mode (lattice units)."""
        return self.population_variance * MODE_NORMS

    @property
    def thermal_mach_number_sq(self) -> float:
        """k_BT/(ρ₀ a³ c_s²) with the physical c_s² = a²/(3τ²), = ⟨δρ²⟩/ρ₀² at a node:
        the size of the nonlinear corrections to the linearised fluctuations."""
        return self.population_variance / self.density**2


def modes(populations, count: int = N_VELOCITIES):
    """The first `count` modes m_k = Σ_i e_ki f_i over the leading axis: (19, ...) →
    (count, ...)."""
    basis = jnp.asarray(MODE_BASIS[:count], populations.dtype)
    return jnp.einsum("ki,i...->k...", basis, populations)


def populations_from_modes(mode_values):
    """f = E⁻¹ m over the leading axis: (K, ...) → (19, ...), the modes beyond the
    K given (K ≤ 19) taken as zero (a deterministic collision leaves the ghosts zero)."""
    inverse = jnp.asarray(INVERSE_MODE_BASIS[:, : len(mode_values)], mode_values.dtype)
    return jnp.einsum("ik,k...->i...", inverse, mode_values)


def _wrapped_pieces(shift: int, n: int):
    """(source slice, destination start) pairs that move a periodic axis of n nodes by
    `shift` ∈ {−1, 0, 1}: the bulk, and the plane that wraps around."""
    if shift == 0:
        return [(slice(0, n), 0)]
    if shift == 1:
        return [(slice(0, n - 1), 1), (slice(n - 1, n), 0)]
    return [(slice(1, n), 0), (slice(0, 1), n - 1)]


def stream(populations, into=None):
    """f_i(r + c_i) ← f_i(r) on the periodic lattice; (19, n_x, n_y, n_z).

    The shifted blocks (1, 2 or 4 per population: the bulk and the wrapped planes) are
    written by in-place slice updates of `into`, an array of the populations' shape
    whose values are no longer needed (e.g. the pre-collision populations of the same
    step); every element is overwritten.  XLA:CPU runs these updates as in-place
    copies, where `jnp.roll` and `jnp.stack` are slower concatenates
    (docs/performance_solvents.md).  Without `into`, a copy of the populations serves
    as the buffer.
    """
    out = populations if into is None else into
    n_x, n_y, n_z = populations.shape[1:]
    for i, (c_x, c_y, c_z) in enumerate(VELOCITIES):
        for source_x, x in _wrapped_pieces(int(c_x), n_x):
            for source_y, y in _wrapped_pieces(int(c_y), n_y):
                for source_z, z in _wrapped_pieces(int(c_z), n_z):
                    block = populations[i : i + 1, source_x, source_y, source_z]
                    out = jax.lax.dynamic_update_slice(out, block, (i, x, y, z))
    return out


def stress_modes(a, b):
    """Modes 4–9 of the symmetric tensor (a ⊗ b + b ⊗ a)/2 (lattice basis rows).

    Args:
        a, b: (3, ...) vector fields.
    Returns:
        (6, ...): [tr, 3T_xx − tr, T_yy − T_zz, T_xy, T_yz, T_xz].
    """
    diagonal = a * b
    trace = diagonal[0] + diagonal[1] + diagonal[2]
    return jnp.stack(
        [
            trace,
            3 * diagonal[0] - trace,
            diagonal[1] - diagonal[2],
            0.5 * (a[0] * b[1] + a[1] * b[0]),
            0.5 * (a[1] * b[2] + a[2] * b[1]),
            0.5 * (a[0] * b[2] + a[2] * b[0]),
        ]
    )


def mass_and_momentum(populations):
    """Σ_i f_i (n_x, n_y, n_z) and the lattice momentum density j = Σ_i f_i c_i (3, ...)
    of populations or of their deviations (then the first is ρ − ρ₀; j is the same).

    Sums of population slices rather than a 4 × 19 dot, whose reshaped operand makes
    XLA:CPU copy the populations that `stream` updated in place
    (docs/performance_solvents.md)."""

    def total(indices):
        return sum((populations[i] for i in indices[1:]), populations[indices[0]])

    momentum = [
        total(np.flatnonzero(VELOCITIES[:, axis] > 0))
        - total(np.flatnonzero(VELOCITIES[:, axis] < 0))
        for axis in range(3)
    ]
    return total(range(N_VELOCITIES)), jnp.stack(momentum)


def equilibrium_deviations(density, velocity, rest_density: float):
    """Deviation of the second-order equilibrium from the rest state w_i ρ₀:

        f_i^eq − w_i ρ₀ = w_i [(ρ − ρ₀) + ρ (c·u/c_s² + (c·u)²/(2c_s⁴) − u²/(2c_s²))].

    Args:
        density: ρ (...).
        velocity: (3, ...) in lattice units (a/τ).
        rest_density: ρ₀.
    Returns:
        (19, ...) deviations, dtype of `velocity`.
    """
    dtype = velocity.dtype
    c = jnp.asarray(VELOCITIES, dtype)
    w = jnp.asarray(WEIGHTS, dtype).reshape((-1,) + (1,) * density.ndim)
    cu = jnp.tensordot(c, velocity, axes=1)
    u_sq = jnp.sum(velocity * velocity, axis=0)
    cs2 = SOUND_SPEED_SQ
    flow = cu / cs2 + cu * cu / (2 * cs2 * cs2) - u_sq / (2 * cs2)
    return w * ((density - rest_density) + density * flow)


def lattice_update(
    parameters: FluidParameters, dtype, noise_law: str = "uniform", sheared_stream=None
):
    """The LB step: collide (with applied impulse and noise), then stream.

    Args:
        parameters: the fluid.
        dtype: floating dtype of the populations.
        noise_law: "uniform" or "gaussian" unit-variance ξ_k (used when k_BT > 0;
            Gaussian variates make the step several times slower on a CPU,
            benchmarks/lattice_boltzmann_throughput.py).
        sheared_stream: None for the periodic lattice, or the streaming across a
            Lees–Edwards boundary (jaxdpd.solvents.lattice_boltzmann.lees_edwards
            .sheared_stream); then `update` takes its (offset, jump) as `boundary`.
    Returns:
        `update(deviations, impulse_density, key, boundary=()) -> (deviations, density,
        velocity)`, pure:
        deviations f_i − w_i ρ₀ (19, n_x, n_y, n_z) before collision; impulse_density (3, ...)
        the momentum per volume given to the fluid over this step (physical units,
        e.g. by the beads' friction), applied as a force density impulse/τ; key the
        uint32 noise key of this LB step (counter_noise.family_key).  Returns the
        deviations after streaming, their density ρ (n_x, n_y, n_z) and physical
        velocity j a/(ρ τ) (3, ...).
    """
    gammas = parameters.relaxation_eigenvalues
    stress_gammas = jnp.asarray(gammas[4:10], dtype).reshape(6, 1, 1, 1)
    impulse_to_lattice = parameters.time_step / parameters.grid_spacing
    speed = parameters.lattice_speed
    n_nodes = parameters.n_nodes
    thermal = parameters.kT > 0
    if thermal:
        fluctuating = np.asarray(FLUCTUATING_MODES)
        amplitude = np.sqrt((1 - gammas[fluctuating] ** 2) * parameters.mode_variances[fluctuating])
        # f* = E⁻¹ m* in one dot: the 10 relaxed hydrodynamic modes, then the noise of
        # modes 4-18 as 15 more columns (a ghost's m* is its noise alone)
        hydrodynamic = INVERSE_MODE_BASIS[:, : len(HYDRODYNAMIC_MODES)]
        noise = INVERSE_MODE_BASIS[:, fluctuating] * amplitude
        noisy_inverse = jnp.asarray(np.concatenate([hydrodynamic, noise], axis=1), dtype)
        draw = counter_noise.NOISE_LAWS[noise_law]

    rest_density = jnp.asarray(parameters.density, dtype)

    def update(deviations, impulse_density, key, boundary=()):
        m = modes(deviations, len(HYDRODYNAMIC_MODES))  # a ghost's m* is its noise alone
        density, momentum = rest_density + m[0], m[1:4]
        impulse = (impulse_to_lattice * impulse_density).astype(dtype)
        velocity = (momentum + 0.5 * impulse) / density
        equilibrium = density * stress_modes(velocity, velocity)
        stress = (
            equilibrium
            + stress_gammas * (m[4:10] - equilibrium)
            + (1 + stress_gammas) * stress_modes(velocity, impulse)
        )
        relaxed = jnp.concatenate([m[:1], momentum + impulse, stress])
        if thermal:
            xi = draw(key, n_nodes, len(FLUCTUATING_MODES), dtype).reshape((-1, *m.shape[1:]))
            modes_and_noise = jnp.concatenate([relaxed, xi])
            post_collision = jnp.einsum("ik,k...->i...", noisy_inverse, modes_and_noise)
        else:
            post_collision = populations_from_modes(relaxed)
        if sheared_stream is None:
            streamed = stream(post_collision, into=deviations)
        else:
            streamed = sheared_stream(post_collision, density, relaxed[1:4], *boundary)
        new_mass, new_momentum = mass_and_momentum(streamed)
        new_density = rest_density + new_mass
        return streamed, new_density, speed * new_momentum / new_density

    return update


def thermal_deviations(parameters: FluidParameters, rng, dtype) -> np.ndarray:
    """Deviations f_i − w_i ρ₀ of a fluid at rest drawn from its equilibrium
    distribution: √(μ w_i) ξ_i with the per-population lattice mean of ξ removed, so
    the total mass is exactly N_nodes ρ₀ a³ and the total momentum exactly zero.

    Args:
        parameters: the fluid.
        rng: a NumPy Generator (host-side draw, as jaxdpd.geometry.placement does).
        dtype: floating dtype.
    Returns:
        (19, n_x, n_y, n_z) NumPy array.
    """
    shape = (N_VELOCITIES, *parameters.nodes)
    if parameters.kT == 0:
        return np.zeros(shape, dtype)
    xi = rng.normal(size=shape)
    xi -= xi.mean(axis=(1, 2, 3), keepdims=True)
    w = WEIGHTS.reshape(-1, 1, 1, 1)
    return (np.sqrt(parameters.population_variance * w) * xi).astype(dtype)
