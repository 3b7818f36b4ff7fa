"""Initial configurations: solvent uniformly at random, chains as random walks.

Chains start at uniformly random points and grow by random unit steps of the bond
law's placement length (the energy minimum, or a free spring's root-mean-square
length), so no spring starts overstretched; a FENE spring is placed at its exact
equilibrium ⟨Q²⟩^{1/2} (thesis eq. 4.8), well inside Q0.  Velocities are
Maxwell–Boltzmann at the solvent's k_BT with zero total momentum.
"""

import jax
import jax.numpy as jnp


def initial_configuration(scene, box, dtype, blocks):
    """The starting state of `scene`'s seed.

    Args:
        scene: the Scene.
        box: its periodic box.
        dtype: floating dtype.
        blocks: the scene's ChainBlocks (jaxdpd.topology.chain_blocks).
    Returns:
        positions (N, 3) wrapped, image (N, 3) int32 counters consistent with
        unbroken chains, velocities (N, 3), species (N,) int32 (species in blocks).
    """
    n = scene.n_particles
    seed_key = jax.random.PRNGKey(scene.seed)
    key_positions, key_velocities = jax.random.split(seed_key)
    key_chains = jax.random.fold_in(seed_key, 1)
    lengths = box.lengths_array(dtype)
    positions = jax.random.uniform(key_positions, (n, 3), dtype) * lengths
    for block, key in zip(blocks, jax.random.split(key_chains, max(len(blocks), 1)), strict=False):
        positions = positions.at[block.first : block.stop].set(
            _random_walks(key, block, lengths, dtype).reshape(-1, 3)
        )
    positions, image = box.wrap(positions, jnp.zeros((n, 3), jnp.int32))
    kT = scene.solvent.kT if scene.solvent.method == "dpd" else 1.0
    velocities = jax.random.normal(key_velocities, (n, 3), dtype) * jnp.sqrt(jnp.asarray(kT, dtype))
    velocities = velocities - jnp.mean(velocities, axis=0)
    counts = [s.count for s in scene.particles.species]
    species = jnp.repeat(
        jnp.arange(len(counts), dtype=jnp.int32), jnp.asarray(counts), total_repeat_length=n
    )
    return positions, image, velocities, species


def _random_walks(key, block, lengths, dtype):
    """(C, M, 3) unwrapped chains: random start, M − 1 random steps of fixed length."""
    key_start, key_steps = jax.random.split(key)
    start = jax.random.uniform(key_start, (block.n_chains, 1, 3), dtype) * lengths
    steps = jax.random.normal(key_steps, (block.n_chains, block.beads - 1, 3), dtype)
    steps = steps / jnp.linalg.norm(steps, axis=-1, keepdims=True) * block.law.placement_length
    return jnp.concatenate([start, start + jnp.cumsum(steps, axis=1)], axis=1)
