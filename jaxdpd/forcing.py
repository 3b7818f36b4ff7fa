"""External body forces.

Cosine forcing ("periodic Poiseuille" flow): every particle feels

    f_x(y) = F cos(2π n y / L_y),

which drives, in a Newtonian fluid of number density ρ and viscosity η, the steady
profile u_x(y) = ρ F / (η k²) cos(k y), k = 2π n / L_y (Stokes: η u'' + ρ f = 0).
Measuring the amplitude gives η = ρ F / (k² A) independently of any shear boundary
(Backer, Lowe, Hoefsloot & Iedema, J. Chem. Phys. 122, 154503 (2005)).  The force
does work, so it needs a thermostat; it is no pair force and adds nothing to the
virial.
"""

import math

import jax.numpy as jnp


def cosine_wavenumber(length_y: float, waves: int) -> float:
    """k = 2π n / L_y of the forcing."""
    return 2 * math.pi * waves / length_y


def cosine_body_force(amplitude: float, waves: int, length_y: float, dtype):
    """`force(positions) -> (N, 3)` of the cosine forcing along x, varying along y.

    Args:
        amplitude: F, force per particle (energy/length).
        waves: n ≥ 1 periods across the box.
        length_y: L_y.
        dtype: floating dtype of the simulation.
    """
    k = jnp.asarray(cosine_wavenumber(length_y, waves), dtype)
    force = jnp.asarray(amplitude, dtype)

    def body_force(positions):
        f_x = force * jnp.cos(k * positions[:, 1])
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
