"""Initial configurations: solvent uniformly at random, chains as random walks.

Chains start at uniformly random points and grow by random unit steps of the bond
law's placement length (the energy minimum, or a free spring's root-mean-square
length), so no spring starts overstretched; a FENE spring is placed at its exact
equilibrium ⟨Q²⟩^{1/2} (thesis eq. 4.8), well inside Q0.  Velocities are
Maxwell–Boltzmann at the solvent's k_BT (variance k_BT/m per component) with zero
total momentum; for a Hoogerbrugge–Koelman solvent, which sets no temperature, at
its solvent.initial_kT (jaxdpd.scene), and the springs are placed for it too.

With a hard-core pair force (a pair law with a `core_diameter` σ, pair.kind = "wca")
overlapping particles would start with enormous forces, so every particle is then
placed at least σ away (minimum image) from all earlier ones, except a chain bead
from its predecessor: chains grow as self-avoiding walks (a trapped chain is
regrown), free particles are drawn until they fit.  Either placement gives up with a
ValueError after PLACEMENT_SECONDS of wall time rather than hang on a box too crowded
(or too large) for it.

With [spring_repulsion] a crossing or nearly touching spring pair would start tens of
k_BT up the repulsion's energy (A = 100 k_BT at contact for the Kumar–Larson law),
enough to tear a FENE spring; the chains then grow as walks whose every new spring
keeps at least the repulsion range from all earlier springs sharing no bead with it
(exact segment closest approach, jaxdpd.forces.spring_repulsion; a trapped chain is regrown).

The configuration is drawn on the host with NumPy's PCG64 generator seeded by the
scene's seed (no device compilation for a one-off), then cast to the scene's dtype.

Positions and velocities may be given instead (`init_fn(positions=...,
velocities=...)`, a scene's [initial] file): positions in any periodic image, each
chain unbroken (its springs as the vectors between consecutive beads), are wrapped
into the box with image counters, as drawn ones are; velocities not given are drawn.
"""

import time

import jax
import jax.numpy as jnp
import numpy as np

from jaxdpd.forces.pair_laws import PAIR_LAWS
from jaxdpd.forces.spring_repulsion import closest_approach


def initial_configuration(scene, box, dtype, blocks, given_positions=None, velocities=None):
    """The starting state of `scene`'s seed.

    Args:
        scene: the Scene.
        box: its periodic box.
        dtype: floating dtype.
        blocks: the scene's ChainBlocks (jaxdpd.geometry.chain_topology.chain_blocks).
        given_positions: (N, 3) positions to start from (module docstring), or None.
        velocities: (N, 3) velocities to start from, or None.
    Returns:
        positions (N, 3) wrapped, image (N, 3) int32 counters consistent with
        unbroken chains, velocities (N, 3), species (N,) int32 (species in blocks).
    Raises:
        ValueError: given positions or velocities of another shape, not finite, or
            in a Kraynik–Reinelt box (whose initial cell is tilted).
    """
    n = scene.n_particles
    rng = np.random.default_rng(scene.seed)
    lengths = np.asarray(box.lengths, np.float64)
    core = None if scene.pair is None else PAIR_LAWS.get(scene.pair.kind).core_diameter(scene.pair)
    if given_positions is not None:
        if getattr(box, "cartesian_at_start", None) is not None:
            raise ValueError("init_fn: positions cannot be given in a Kraynik–Reinelt box")
        unwrapped = _given(given_positions, "positions", n)
    elif core is not None:
        unwrapped = _excluded_volume_configuration(rng, n, blocks, lengths, core)
    else:
        unwrapped = rng.uniform(size=(n, 3)) * lengths
        for block in blocks:
            walks = _random_walks(rng, block, lengths)
            unwrapped[block.first : block.stop] = walks.reshape(-1, 3)
        if scene.spring_repulsion is not None:
            _spring_avoiding_walks(rng, unwrapped, blocks, lengths, scene.spring_repulsion.range)
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
    counts = [s.count for s in scene.particles.species]
    species = np.repeat(np.arange(len(counts), dtype=np.int32), counts)
    masses = np.array([s.mass for s in scene.particles.species])[species]
    if velocities is not None:
        velocities = _given(velocities, "velocities", n)
    else:
        velocities = rng.normal(size=(n, 3)) * np.sqrt(scene.solvent.kT / masses)[:, None]
        velocities -= (masses @ velocities) / masses.sum()
    return (
        jnp.asarray(positions),
        jnp.asarray(image, jnp.int32),
        jnp.asarray(velocities, dtype),
        jnp.asarray(species),
    )


def _given(values, name: str, n: int) -> np.ndarray:
    """`values` as a float64 (N, 3) array, or a ValueError naming `name`."""
    values = np.asarray(values, np.float64)
    if values.shape != (n, 3) or not np.all(np.isfinite(values)):
        raise ValueError(
            f"init_fn: {name} must be a finite (N, 3) array for the scene's N = {n} "
            f"particles, got shape {values.shape}"
        )
    return values


def _random_walks(rng, block, lengths):
    """(C, M, 3) unwrapped chains: random start, M − 1 random steps of fixed length."""
    start = rng.uniform(size=(block.n_chains, 1, 3)) * lengths
    steps = rng.normal(size=(block.n_chains, block.beads - 1, 3))
    steps *= block.law.placement_length / np.linalg.norm(steps, axis=-1, keepdims=True)
    return np.concatenate([start, start + np.cumsum(steps, axis=1)], axis=1)


MAX_ATTEMPTS = 1000
# Wall-time bound of the rejection placements (hard cores, spring clearance).
PLACEMENT_SECONDS = 120.0


class _Deadline:
    """Raises ValueError naming `field` once PLACEMENT_SECONDS have passed."""

    def __init__(self, field: str, total: int):
        self.field, self.total = field, total
        self.end = time.monotonic() + PLACEMENT_SECONDS

    def check(self, placed: int) -> None:
        if time.monotonic() > self.end:
            raise ValueError(
                f"{self.field}: placing {self.total} particles gave up after "
                f"{PLACEMENT_SECONDS:g} s with {placed} placed; the box is too crowded for "
                "random placement (fewer particles or chains, or a larger box)"
            )


def _spring_avoiding_walks(rng, unwrapped, blocks, lengths, clearance: float):
    """Regrow the chains of `unwrapped` (in place) so that no two springs sharing no
    bead come closer than `clearance` (minimum image of the midpoint separation).

    Raises:
        ValueError: when a chain cannot be grown (the chains are too crowded).
    """
    n_springs = sum(block.n_chains * (block.beads - 1) for block in blocks)
    # Placed springs in fixed-size arrays (one compilation of the distance kernel);
    # unplaced slots are marked absent.
    midpoints = np.zeros((n_springs, 3))
    springs = np.zeros((n_springs, 3))
    lengths_array = jnp.asarray(lengths)
    distances = _spring_distance_kernel()

    def clear(first, bond, placed, previous_shares_bead):
        """Whether spring first → first + bond keeps `clearance` from springs
        [0, placed), except the last of them when it is its predecessor on the chain."""
        others = placed - 1 if previous_shares_bead else placed
        if others == 0:
            return True
        near = distances(
            jnp.asarray(first + 0.5 * bond),
            jnp.asarray(bond),
            jnp.asarray(midpoints),
            jnp.asarray(springs),
            lengths_array,
        )
        return bool(np.all(np.asarray(near)[:others] >= clearance))

    spring = 0
    deadline = _Deadline("spring_repulsion", len(unwrapped))
    for block in blocks:
        bond_length = block.law.placement_length
        for c in range(block.n_chains):
            first_bead = block.first + c * block.beads
            for _ in range(MAX_ATTEMPTS):
                unwrapped[first_bead] = rng.uniform(size=3) * lengths
                for k in range(1, block.beads):
                    for _ in range(MAX_ATTEMPTS):
                        deadline.check(first_bead + k)
                        step = rng.normal(size=3)
                        bond = bond_length * step / np.linalg.norm(step)
                        start = unwrapped[first_bead + k - 1]
                        if clear(start, bond, spring + k - 1, k > 1):
                            unwrapped[first_bead + k] = start + bond
                            midpoints[spring + k - 1] = start + 0.5 * bond
                            springs[spring + k - 1] = bond
                            break
                    else:
                        break  # trapped: regrow the chain
                else:
                    break
            else:
                raise ValueError(
                    f"spring_repulsion: could not grow the chain starting at particle "
                    f"{first_bead} with its springs spring_repulsion.range = {clearance} "
                    "from all others; the chains are too crowded (fewer or shorter chains, "
                    "or a larger box)"
                )
            spring += block.beads - 1


def _spring_distance_kernel():
    """Jitted `(midpoint, spring, midpoints, springs, lengths) -> (S,)` closest
    approaches of one spring to many (minimum image of the midpoint separations)."""

    def kernel(midpoint, spring, midpoints, springs, lengths):
        separation = midpoint - midpoints
        separation = separation - lengths * jnp.round(separation / lengths)
        return closest_approach(
            separation, jnp.broadcast_to(spring, springs.shape), springs
        ).distance

    return jax.jit(kernel)


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

    deadline = _Deadline("particles", n)

    def place_free(index):
        for _ in range(MAX_ATTEMPTS):
            deadline.check(index)
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
                    deadline.check(k)
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
