"""Exact linear response of the lattice-Boltzmann fluid, by Fourier analysis.

Around a fluid at rest (ρ₀, u = 0) without noise, one LB step is linear in the
populations.  For a wave vector k on the lattice (f(r) = Σ_k f̂(k) e^{ik·r}) it maps

    f̂ ← S(k) [C f̂ + E⁻¹ ĝ],   S = diag(e^{−i k·c_i a}),   C = E⁻¹ diag(γ_k) E,

with ĝ the applied impulse in the momentum modes (jaxdpd.solvents.lattice_boltzmann.fluid:
at linear order the stress equilibrium ρuu and the forcing term u g drop out).  From
this 19 × 19 propagator follow, with no time stepping (Lallemand and Luo, Phys. Rev. E
61, 6546 (2000) do the same analysis for the dispersion of lattice-Boltzmann models):

- the decay rate of every mode at any k (shear waves, sound), whose small-k limit is
  the hydrodynamics of the input viscosities: ν k² for a transverse wave and
  (2ν/3 + ν_b/2) k² for the amplitude of a sound wave (Landau & Lifshitz, Fluid
  Mechanics, §79);
- the steady velocity field of a constant force density (the lattice Stokeslet),
  solving (1 − S C) f̂ = S E⁻¹ ĝ mode by mode, and from it the hydrodynamic part of
  the mobility of a point particle coupled by trilinear interpolation, which sets
  its effective friction (Ahlrichs & Dünweg, J. Chem. Phys. 111, 8225 (1999), §II.C,
  eqs. 17–20): 1/ζ_eff = 1/ζ_bare + μ_lattice.  μ_lattice includes the finite periodic
  box exactly (the k = 0 force is removed, i.e. a uniform counter force holds the
  total momentum at zero, as in Hasimoto, J. Fluid Mech. 5, 317 (1959)); for large
  boxes μ_lattice → 1/(g η a) − HASIMOTO_CONSTANT/(6π η L) (seed eqs. 19, 31; the
  mobility of a sphere in a simple cubic array of period L is (1/(6πηR))(1 −
  HASIMOTO_CONSTANT R/L + O(R³/L³))).

Host-side NumPy (complex128), for predictions and tests.
"""

import numpy as np

from jaxdpd.analysis.periodic_hydrodynamics import HASIMOTO_CONSTANT
from jaxdpd.solvents.lattice_boltzmann.fluid import FluidParameters
from jaxdpd.solvents.lattice_boltzmann.lattice import (
    INVERSE_MODE_BASIS,
    MODE_BASIS,
    VELOCITIES,
)

__all__ = [
    "HASIMOTO_CONSTANT",
    "decay_rates",
    "friction_mobility",
    "point_force_response",
    "point_particle_mobility",
    "propagator",
    "transverse_wave_decay_rate",
]


def lattice_wave_vectors(nodes) -> np.ndarray:
    """(n_x, n_y, n_z, 3) wave vectors 2π n_α/N_α in units of 1/a, FFT order."""
    axes = [2 * np.pi * np.fft.fftfreq(n) * n / n for n in nodes]
    grids = np.meshgrid(*axes, indexing="ij")
    return np.stack(grids, axis=-1)


def propagator(fluid: FluidParameters, wave_vectors) -> np.ndarray:
    """One LB step of the linearised, noise-free fluid at wave vectors k.

    Args:
        fluid: the fluid.
        wave_vectors: (..., 3) in units of 1/a.
    Returns:
        (..., 19, 19) complex S(k) C.
    """
    collision = INVERSE_MODE_BASIS @ np.diag(fluid.relaxation_eigenvalues) @ MODE_BASIS
    phases = np.exp(-1j * np.asarray(wave_vectors) @ VELOCITIES.T)  # (..., 19)
    return phases[..., :, None] * collision


def decay_rates(fluid: FluidParameters, wave_vector) -> np.ndarray:
    """Complex rates s = −ln(λ)/τ of the propagator's eigenvalues λ at one k, sorted by
    real part (slowest first): Re s is the decay rate, Im s the angular frequency."""
    eigenvalues = np.linalg.eigvals(propagator(fluid, np.asarray(wave_vector, float)))
    rates = -np.log(eigenvalues.astype(complex)) / fluid.time_step
    return rates[np.argsort(rates.real)]


def transverse_wave_decay_rate(fluid: FluidParameters, wave_number: float) -> float:
    """Decay rate of a shear wave u_x ∝ sin(k y) on the lattice (k in 1/a).

    The slowest eigenvalue of the propagator restricted to k along y that carries
    transverse momentum: obtained from the x-momentum response, which for k ∥ y
    does not mix with density or y-momentum.
    """
    k = np.array([0.0, wave_number, 0.0])
    values, vectors = np.linalg.eig(propagator(fluid, k))
    transverse = np.abs(MODE_BASIS[1] @ vectors)  # x-momentum content
    candidates = np.flatnonzero(transverse > 1e-8 * transverse.max())
    best = candidates[np.argmax(np.abs(values[candidates]))]
    return float(-np.log(np.abs(values[best])) / fluid.time_step)


def point_force_response(fluid: FluidParameters) -> np.ndarray:
    """Steady node velocity per unit force applied at node 0 (the lattice Stokeslet).

    A constant force F at node 0, with the uniform counter force −F/(N a³) on every
    node, gives the steady velocity field u_α(r) = G_αβ(r) F_β, u = j a/(ρ₀ τ) the
    velocity of the populations after streaming (what the fluid module reports).
    Averaged over two LB steps: the lattice has an undamped momentum checkerboard at
    the Nyquist wave vectors (eigenvalue −1 of S C, e.g. k = (π/a, 0, 0) with
    f_i ∝ w_i c_ix), which a steady force drives into a period-2 oscillation about
    this mean.

    Returns:
        (3, 3, n_x, n_y, n_z) G (time/mass).
    """
    nodes = fluid.nodes
    n_nodes = fluid.n_nodes
    k = lattice_wave_vectors(nodes).reshape(-1, 3)
    system = np.eye(19) - propagator(fluid, k)  # (K, 19, 19)
    phases = np.exp(-1j * k @ VELOCITIES.T)  # S(k) diagonal
    # Unit force at node 0 over one LB step: lattice impulse density g = F τ²/a⁴
    # (momentum density τ F/a³ in lattice velocity units), Fourier amplitude g/N.
    impulse = fluid.time_step**2 / fluid.grid_spacing**4 / n_nodes
    nonzero = np.any(k != 0, axis=1)
    sources = INVERSE_MODE_BASIS[:, 1:4] * impulse  # E⁻¹ ĝ for g along x, y, z
    rhs = phases[nonzero][:, :, None] * sources[None]
    f_hat = np.linalg.solve(system[nonzero], rhs)  # (K', 19, 3)
    momentum = np.einsum("kib,ia->abk", f_hat, VELOCITIES.astype(float))  # lattice j
    response = np.zeros((3, 3, k.shape[0]), complex)
    response[:, :, nonzero] = momentum * fluid.lattice_speed / fluid.density
    fields = response.reshape(3, 3, *nodes)
    return np.real(np.fft.ifftn(fields, axes=(2, 3, 4)) * n_nodes)


def _corner_weights(offset) -> tuple[np.ndarray, np.ndarray]:
    """The 8 corner offsets (8, 3) and trilinear weights (8,) of a point at fractional
    position `offset` (3,) in its cell (jaxdpd.solvents.lattice_boltzmann.coupling)."""
    corners = np.array([[dx, dy, dz] for dx in (0, 1) for dy in (0, 1) for dz in (0, 1)])
    offset = np.asarray(offset, float)
    weights = np.prod(np.where(corners == 1, offset, 1 - offset), axis=1)
    return corners, weights


def point_particle_mobility(fluid: FluidParameters, offset, response=None) -> np.ndarray:
    """Hydrodynamic mobility μ of a point particle: u_av = μ F (seed eqs. 17–19).

    The force F is spread on the 8 nodes of the particle's cell with the trilinear
    weights δ_r and the velocity read back with the same weights, so
    μ_αβ = Σ_{r,r'} δ_r δ_r' G_αβ(r − r').

    Args:
        fluid: the fluid.
        offset: (3,) fractional position of the particle in its cell, in [0, 1).
        response: `point_force_response(fluid)` if already computed.
    Returns:
        (3, 3) mobility (time/mass), including the periodic images of the box.
    """
    green = point_force_response(fluid) if response is None else response
    corners, weights = _corner_weights(offset)
    mobility = np.zeros((3, 3))
    nodes = np.asarray(fluid.nodes)
    for corner_a, weight_a in zip(corners, weights, strict=True):
        for corner_b, weight_b in zip(corners, weights, strict=True):
            i, j, k = (corner_a - corner_b) % nodes
            mobility += weight_a * weight_b * green[:, :, i, j, k]
    return mobility


def friction_mobility(
    fluid: FluidParameters, friction: float, mass: float, dt: float, substeps: int, offset
):
    """Drift velocity of a bead relative to the LB velocity it interpolates, per unit
    steady force, from the exact periodic steady state of the MD steps.

    Within one LB step the bead makes n B A O A B steps (jaxdpd.solvents.lattice_boltzmann
    .integrator).  Step s sees u_s = u₀ + κ p_s, with u₀ the interpolated LB velocity,
    p_s the momentum the bead gave its nodes since the last LB step and
    κ = Σ_r δ_r²/(ρ₀ a³) (the same weights spread and read it back).  With the
    friction impulse P = −m_red (1 − e^{−y}) (V − u_s), y = ζ Δt/m_red, and the force
    F in the two half kicks, the velocities are an affine map over one LB step whose
    fixed point gives the mean velocity ⟨V⟩ − u₀ = F μ_f.  For n = 1,
    μ_f = Δt/(m_red (1 − e^{−y})) − Δt/(2M) → 1/ζ as Δt → 0 (seed eq. 17).

    Args:
        fluid: the fluid (ρ₀ a³ is the node mass).
        friction: ζ; mass: M; dt: Δt.
        substeps: n, MD steps per LB step.
        offset: (3,) fractional position in the cell.
    Returns:
        μ_f (time/mass), for a unit force.
    """
    _, weights = _corner_weights(offset)
    node_mass = fluid.density * fluid.grid_spacing**3
    self_mobility = np.sum(weights * weights) / node_mass  # κ
    reduced = 1 / (1 / mass + self_mobility)
    relaxation = -reduced * np.expm1(-friction * dt / reduced)  # m_red (1 − e^{−y})
    kick = 0.5 * dt / mass

    def one_lattice_step(velocity):
        pending, velocities = 0.0, []
        for _ in range(substeps):
            impulse = -relaxation * (velocity + kick - self_mobility * pending)
            velocity = velocity + 2 * kick + impulse / mass
            pending -= impulse
            velocities.append(velocity)
        return velocity, np.mean(velocities)

    offset_end, _ = one_lattice_step(0.0)
    slope = one_lattice_step(1.0)[0] - offset_end
    return one_lattice_step(offset_end / (1 - slope))[1]
