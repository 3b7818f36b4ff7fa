"""Initial configurations: solvent uniformly at random, chains as random walks.

Chains start at uniformly random points and grow by random unit steps of the bond
law's placement length (the energy minimum, or a free spring's root-mean-square
length), so no spring starts overstretched; a FENE spring is placed at its exact
equilibrium ⟨Q²⟩^{1/2} (thesis eq. 4.8), well inside Q0.  Velocities are
Maxwell–Boltzmann at the solvent's k_BT (variance k_BT/m per component) with zero
total momentum.

With a hard-core pair force (pair.kind = "wca") overlapping particles would start
with enormous forces, so every particle is then placed at least σ away (minimum
image) from all earlier ones, except a chain bead from its predecessor: chains grow
as self-avoiding walks (a trapped chain is regrown), free particles are drawn until
they fit.

The configuration is drawn on the host with NumPy's PCG64 generator seeded by the
scene's seed (no device compilation for a one-off), then cast to the scene's dtype.
"""

import jax.numpy as jnp
import numpy as np


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
    rng = np.random.default_rng(scene.seed)
    lengths = np.asarray(box.lengths, np.float64)
    if scene.pair is not None and scene.pair.kind == "wca":
        unwrapped = _excluded_volume_configuration(rng, n, blocks, lengths, scene.pair.sigma)
    else:
        unwrapped = rng.uniform(size=(n, 3)) * lengths
        for block in blocks:
            walks = _random_walks(rng, block, lengths)
            unwrapped[block.first : block.stop] = walks.reshape(-1, 3)
    image = np.floor(unwrapped / lengths).astype(np.int32)
    cartesian_at_start = getattr(box, "cartesian_at_start", None)
    if cartesian_at_start is not None:
        # A box whose cell is tilted at the start (Kraynik–Reinelt) is filled in its
        # frame, a rotated copy of space there, and the result is mapped back.
        positions = np.asarray(cartesian_at_start(unwrapped - image * lengths), dtype)
    else:
        positions = np.asarray(unwrapped - image * lengths, dtype)
        # Rounding to `dtype` can leave a coordinate exactly at L: fold it to 0 and
        # count the crossing.
        at_edge = positions >= lengths.astype(dtype)
        positions = np.where(at_edge, 0, positions).astype(dtype)
        image = image + at_edge
    kT = scene.solvent.kT if scene.solvent.method != "hoogerbrugge_koelman" else 1.0
    counts = [s.count for s in scene.particles.species]
    species = np.repeat(np.arange(len(counts), dtype=np.int32), counts)
    masses = np.array([s.mass for s in scene.particles.species])[species]
    velocities = rng.normal(size=(n, 3)) * np.sqrt(kT / masses)[:, None]
    velocities -= (masses @ velocities) / masses.sum()
    return (
        jnp.asarray(positions),
        jnp.asarray(image, jnp.int32),
        jnp.asarray(velocities, dtype),
        jnp.asarray(species),
    )


def _random_walks(rng, block, lengths):
    """(C, M, 3) unwrapped chains: random start, M − 1 random steps of fixed length."""
    start = rng.uniform(size=(block.n_chains, 1, 3)) * lengths
    steps = rng.normal(size=(block.n_chains, block.beads - 1, 3))
    steps *= block.law.placement_length / np.linalg.norm(steps, axis=-1, keepdims=True)
    return np.concatenate([start, start + np.cumsum(steps, axis=1)], axis=1)


MAX_ATTEMPTS = 1000


def _excluded_volume_configuration(rng, n, blocks, lengths, min_distance: float):
    """(N, 3) unwrapped positions no closer than `min_distance` (minimum image) except
    along chain bonds; chains are self-avoiding walks of their placement length.

    Raises:
        ValueError: when the particles do not fit (the box is too crowded).
    """
    positions = np.empty((n, 3))
    chain_of = {}
    for block in blocks:
        for c in range(block.n_chains):
            start = block.first + c * block.beads
            chain_of[start] = (start, block.beads, block.law.placement_length)

    def fits(candidate, placed, skip=-1):
        separation = positions[:placed] - candidate
        separation -= lengths * np.round(separation / lengths)
        distance_sq = np.sum(separation * separation, axis=1)
        if 0 <= skip < placed:
            distance_sq[skip] = np.inf
        return bool(np.all(distance_sq >= min_distance * min_distance))

    def place_free(index):
        for _ in range(MAX_ATTEMPTS):
            candidate = rng.uniform(size=3) * lengths
            if fits(candidate, index):
                positions[index] = candidate
                return
        raise ValueError(
            f"particles: could not place particle {index} at least pair.sigma = "
            f"{min_distance} from all others; the box is too crowded (lower the count)"
        )

    def grow_chain(start, beads, bond_length):
        for _ in range(MAX_ATTEMPTS):
            place_free(start)
            for k in range(start + 1, start + beads):
                for _ in range(MAX_ATTEMPTS):
                    step = rng.normal(size=3)
                    candidate = positions[k - 1] + bond_length * step / np.linalg.norm(step)
                    if fits(candidate, k, skip=k - 1):
                        positions[k] = candidate
                        break
                else:
                    break  # trapped: regrow the chain
            else:
                return
        raise ValueError(f"particles: could not grow the chain starting at particle {start}")

    index = 0
    while index < n:
        if index in chain_of:
            start, beads, bond_length = chain_of[index]
            grow_chain(start, beads, bond_length)
            index += beads
        else:
            place_free(index)
            index += 1
    return positions
