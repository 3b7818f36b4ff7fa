"""Counter-based, pairwise-symmetric random numbers.

The random number of pair (i, j) at step n is a pure function of
(seed, n, min(i, j), max(i, j)): θ_ij = θ_ji exactly, so pair forces stay
antisymmetric and momentum is conserved to round-off, and a trajectory does not
depend on the neighbour-list format, its capacity or the order of its pairs.
Numbers that belong to one site (a particle, an MPCD collision cell) are drawn the
same way from (seed, n, site) by `site_bits`.

The hash is the 32-bit integer finaliser "lowbias32" (C. Wellons, hash-prospector,
bias ≈ 0.17, better than MurmurHash3's fmix32), chained over the four words.  It is
cheap integer arithmetic that vectorises, unlike per-pair `jax.random` keys.
"""

import jax.numpy as jnp

_GOLDEN = 0x9E3779B9  # 2^32 / golden ratio: decorrelates consecutive counters


def mix32(h):
    """lowbias32 finaliser: a bijection on uint32 with good avalanche.

    Args:
        h: uint32 array.
    Returns:
        uint32 array of the same shape.
    """
    h = h ^ (h >> 16)
    h = h * jnp.uint32(0x21F0AAAD)
    h = h ^ (h >> 15)
    h = h * jnp.uint32(0x735A2D97)
    return h ^ (h >> 15)


def step_key(seed, step):
    """Hash of (seed, step): one uint32 per time step, shared by all pairs.

    Args:
        seed: integer seed (Python int or uint32 array).
        step: step counter (integer array).
    Returns:
        uint32 scalar.
    """
    seed = jnp.asarray(seed).astype(jnp.uint32)
    step = jnp.asarray(step).astype(jnp.uint32)
    return mix32(mix32(seed ^ jnp.uint32(0x5BD1E995)) + step * jnp.uint32(_GOLDEN))


def pair_bits(key, i, j, stream=0):
    """32 random bits for each pair, symmetric in (i, j).

    Args:
        key: uint32 scalar from `step_key`.
        i, j: integer arrays of particle identities (same shape).
        stream: small integer selecting an independent stream for the same pair
            (e.g. two uniforms for a Gaussian).
    Returns:
        uint32 array, shape of i.
    """
    lo = jnp.minimum(i, j).astype(jnp.uint32)
    hi = jnp.maximum(i, j).astype(jnp.uint32)
    h = mix32(key ^ (lo * jnp.uint32(_GOLDEN) + jnp.uint32(stream)))
    return mix32(h + hi)


def site_bits(key, index, stream=0):
    """32 random bits for each site (a particle, a collision cell, ...).

    The diagonal (i, i) of `pair_bits`: pair noise never draws it (i ≠ j), so site
    and pair numbers of the same key are independent.

    Args:
        key: uint32 scalar from `step_key`.
        index: integer array of site identities.
        stream: small integer selecting an independent stream for the same site.
    Returns:
        uint32 array, shape of index.
    """
    return pair_bits(key, index, index, stream)


def bits_to_unit_interval(bits, dtype):
    """Map uint32 bits to a uniform variate on the open interval (0, 1).

    Uses the top 24 bits, so the float32 result is exact; the half-ulp offset keeps
    0 and 1 out (safe for logarithms).
    """
    top = (bits >> 8).astype(dtype)
    return (top + jnp.asarray(0.5, dtype)) * jnp.asarray(2.0**-24, dtype)


def pair_uniform_unit_variance(key, i, j, dtype):
    """Uniform variate on [-√3, √3] (zero mean, unit variance), symmetric in (i, j).

    Groot and Warren (J. Chem. Phys. 107, 4423 (1997)) report that uniform θ_ij
    gives results indistinguishable from Gaussian θ_ij (thesis §2.1).
    """
    u = bits_to_unit_interval(pair_bits(key, i, j), dtype)
    return (u * 2 - 1) * jnp.sqrt(jnp.asarray(3.0, dtype))


def pair_gaussian(key, i, j, dtype, stream=0):
    """Standard normal variate, symmetric in (i, j) (Box–Muller on the two bit
    streams 2·stream and 2·stream + 1; another `stream` gives an independent one)."""
    u1 = bits_to_unit_interval(pair_bits(key, i, j, stream=2 * stream), dtype)
    u2 = bits_to_unit_interval(pair_bits(key, i, j, stream=2 * stream + 1), dtype)
    return jnp.sqrt(-2 * jnp.log(u1)) * jnp.cos(2 * jnp.pi * u2)


def pair_uniform(key, i, j, low, high, dtype):
    """Uniform variate on [low, high), symmetric in (i, j)."""
    u = bits_to_unit_interval(pair_bits(key, i, j), dtype)
    return low + (high - low) * u
