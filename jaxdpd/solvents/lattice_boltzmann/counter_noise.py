"""Counter-based random variates for lattice nodes and beads.

The variate of stream s (a mode, a Cartesian component) of site n (a lattice node, a
bead) at step t is a pure function of (seed, t, n, s), as jaxdpd.engine.noise does for
particle pairs: no `jax.random` key is threaded through the state, and a trajectory
does not depend on how the lattice or the beads are batched.  The site and stream
form one 32-bit counter n·S + s (unique while n·S < 2³², checked by the callers that
size the lattice), and two rounds of the lowbias32 finaliser (jaxdpd.engine.noise.mix32,
a bijection for a fixed key) turn it into 32 random bits.

Separate families (lattice noise, bead noise) use separate salts, so the streams of
the LB fluid, the beads and the DPD pairs (jaxdpd.engine.noise.step_key) never coincide.
"""

import jax.numpy as jnp

from jaxdpd.engine import noise

LATTICE_SALT = 0x4C42F1D3  # "LB" fluid modes
BEAD_SALT = 0xB3AD5A17  # friction coupling noise of the beads
MAX_COUNTER = 2**32


def family_key(seed, step, salt: int):
    """uint32 key of one family of variates at one step.

    Args:
        seed: integer seed (Python int or uint32 array).
        step: step counter of the family (LB steps for the fluid, MD steps for beads).
        salt: a 32-bit constant naming the family.
    """
    return noise.mix32(noise.step_key(seed, step) ^ jnp.uint32(salt))


def counter_bits(key, counter):
    """32 random bits per counter; a bijection of the counter for a fixed key.

    Args:
        key: uint32 scalar from `family_key`.
        counter: uint32 array of counters n·S + s.
    Returns:
        uint32 array, shape of `counter`.
    """
    return noise.mix32(noise.mix32(counter ^ key) + noise.mix32(key ^ jnp.uint32(0x85EBCA6B)))


def _counters(n_sites: int, n_streams: int):
    """(n_streams, n_sites) uint32 counters n·S + s."""
    if n_sites * n_streams > MAX_COUNTER:
        raise ValueError(
            f"counter noise: {n_sites} sites × {n_streams} streams exceed 2³² counters"
        )
    sites = jnp.arange(n_sites, dtype=jnp.uint32)[None, :] * jnp.uint32(n_streams)
    return sites + jnp.arange(n_streams, dtype=jnp.uint32)[:, None]


def standard_normal(key, n_sites: int, n_variates: int, dtype):
    """Independent N(0, 1) variates for every (stream, site), by Box–Muller.

    Each pair of streams (2p, 2p + 1) gives two variates, r cos θ and r sin θ.

    Args:
        key: uint32 scalar from `family_key`.
        n_sites: number of sites (static).
        n_variates: variates per site (static).
        dtype: floating dtype.
    Returns:
        (n_variates, n_sites) array.
    """
    n_pairs = (n_variates + 1) // 2
    bits = counter_bits(key, _counters(n_sites, 2 * n_pairs))
    u1 = noise.bits_to_unit_interval(bits[0::2], dtype)
    u2 = noise.bits_to_unit_interval(bits[1::2], dtype)
    radius = jnp.sqrt(-2 * jnp.log(u1))
    angle = jnp.asarray(2 * jnp.pi, dtype) * u2
    return jnp.concatenate([radius * jnp.cos(angle), radius * jnp.sin(angle)])[:n_variates]


def uniform_unit_variance(key, n_sites: int, n_variates: int, dtype):
    """Independent uniform variates on [−√3, √3] (zero mean, unit variance).

    Cheaper than `standard_normal` (no transcendental functions); fluctuation–
    dissipation needs only the first two moments of the noise (Dünweg, Schiller and
    Ladd, Phys. Rev. E 76, 036704 (2007), §III).

    Returns:
        (n_variates, n_sites) array.
    """
    bits = counter_bits(key, _counters(n_sites, n_variates))
    u = noise.bits_to_unit_interval(bits, dtype)
    return (2 * u - 1) * jnp.sqrt(jnp.asarray(3.0, dtype))


NOISE_LAWS = {"gaussian": standard_normal, "uniform": uniform_unit_variance}
