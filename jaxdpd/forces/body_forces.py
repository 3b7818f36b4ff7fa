"""External body forces.

Cosine forcing ("periodic Poiseuille" flow): every particle feels

    f_x(y) = F cos(2π n y / L_y),

which drives, in a Newtonian fluid of number density ρ and viscosity η, the steady
profile u_x(y) = ρ F / (η k²) cos(k y), k = 2π n / L_y (Stokes: η u'' + ρ f = 0).
Measuring the amplitude gives η = ρ F / (k² A) independently of any shear boundary
(Backer, Lowe, Hoefsloot & Iedema, J. Chem. Phys. 122, 154503 (2005)).  The force
does work, so it needs a thermostat; it is no pair force and adds nothing to the
virial.

Tagged-particle forcing (the drag coefficient, thesis §4.2.4): a force F x̂ on each
of the k particles of one species and −k F/(N − k) x̂ on every other particle, so the
total force vanishes and momentum is conserved (the thesis's −F_b/(N − 1) for k = 1).
The tagged particles drift through the rest with ⟨v_T − v_R⟩ = F/ζ
(jaxdpd.observables.drag).

Both factories return `force(positions, amplitude) -> (N, 3)`; the amplitude is read
from `SimState.parameters["body_force"]` (jaxdpd.engine.parameters), so it may differ
between the replicas of an ensemble.
"""

import math

import jax.numpy as jnp


def cosine_wavenumber(length_y: float, waves: int) -> float:
    """k = 2π n / L_y of the forcing."""
    return 2 * math.pi * waves / length_y


def cosine_body_force(waves: int, length_y: float, dtype):
    """`force(positions, amplitude) -> (N, 3)` of the cosine forcing along x, varying
    along y.

    Args:
        waves: n ≥ 1 periods across the box.
        length_y: L_y.
        dtype: floating dtype of the simulation.
    Returns:
        The force law; `amplitude` is F, force per particle (energy/length).
    """
    k = jnp.asarray(cosine_wavenumber(length_y, waves), dtype)

    def body_force(positions, amplitude):
        f_x = amplitude * jnp.cos(k * positions[:, 1])
        return jnp.zeros_like(positions).at[:, 0].set(f_x)

    return body_force


def tagged_body_force(first: int, count: int, n_particles: int, dtype):
    """`force(positions, amplitude) -> (N, 3)`: F x̂ on the tagged particles
    `first .. first + count − 1`, −F count/(N − count) x̂ on all others (thesis
    §4.2.4).

    The forces sum to zero up to round-off (a relative 1e-7 of F in float32), so the
    total momentum is conserved.

    Args:
        first: index of the first tagged particle.
        count: k ≥ 1 tagged particles (contiguous, e.g. one species).
        n_particles: N > k.
        dtype: floating dtype of the simulation.
    Returns:
        The force law; `amplitude` is F (energy/length) on each tagged particle.
    """
    if not 1 <= count < n_particles or not 0 <= first <= n_particles - count:
        raise ValueError(
            f"tagged_body_force: particles {first}..{first + count - 1} must be a non-empty "
            f"part of the N = {n_particles} particles, leaving at least one untagged"
        )
    tagged = jnp.zeros(n_particles, bool).at[first : first + count].set(True)
    compensation = jnp.asarray(-count / (n_particles - count), dtype)

    def body_force(positions, amplitude):
        f_x = amplitude * jnp.where(tagged, jnp.asarray(1, dtype), compensation)
        return jnp.zeros_like(positions).at[:, 0].set(f_x)

    return body_force


def cosine_profile_amplitude(bin_centres, mean_velocity, length_y: float, waves: int):
    """Amplitude A of u_x = A cos(k y) from velocities averaged in equal bins along y.

    Projects the binned profile on cos(k y) and divides by the bin average of the
    cosine, sinc(k Δy / 2), so a profile that is exactly A cos(k y) gives A back.

    Args:
        bin_centres: (B,) bin centres on [0, L_y).
        mean_velocity: (..., B) mean u_x per bin.
    Returns:
        (...) amplitudes.
    """
    k = cosine_wavenumber(length_y, waves)
    width = length_y / len(bin_centres)
    projection = 2 * jnp.mean(mean_velocity * jnp.cos(k * bin_centres), axis=-1)
    return projection / jnp.sinc(k * width / (2 * jnp.pi))
