"""Polymer topology: which particles form which linear chains.

Particles are stored species after species, so all chains of one `[[polymers]]`
entry occupy a contiguous index range, chain after chain and, within a chain, bead
after bead.  A block of C chains of M beads is then an array reshape, and the
springs of a chain join neighbouring rows: no bond index lists are needed.
"""

from dataclasses import dataclass

import jax.numpy as jnp

from jaxdpd.forces.bonds import Bond, bond_law


@dataclass(frozen=True)
class ChainBlock:
    """The chains made of one species.

    Attributes:
        species: species name.
        first: index of the block's first bead.
        n_chains: number of chains C.
        beads: beads per chain M.
        law: the bond law of every spring in the block.
    """

    species: str
    first: int
    n_chains: int
    beads: int
    law: Bond

    @property
    def stop(self) -> int:
        """One past the block's last bead index."""
        return self.first + self.n_chains * self.beads

    def take(self, per_particle):
        """Rows of a per-particle array (N, ...) as chains: (C, M, ...)."""
        rows = per_particle[self.first : self.stop]
        return rows.reshape(self.n_chains, self.beads, *per_particle.shape[1:])


def chain_blocks(scene) -> tuple[ChainBlock, ...]:
    """The scene's polymer blocks, in species order."""
    kT = scene.solvent.kT
    first = {}
    offset = 0
    for species in scene.particles.species:
        first[species.name] = (offset, species.count)
        offset += species.count
    blocks = []
    for polymer in scene.polymers:
        start, count = first[polymer.species]
        blocks.append(
            ChainBlock(
                polymer.species,
                start,
                count // polymer.beads,
                polymer.beads,
                bond_law(polymer.bond_parameters, kT),
            )
        )
    return tuple(sorted(blocks, key=lambda block: block.first))


def chain_coordinates(box, positions, block: ChainBlock, image=None):
    """Bead coordinates of each chain in one piece (thesis §3.2.4, eq. 3.6).

    The first bead keeps its wrapped position; every further bead is placed by the
    spring vectors: with `image`, those of the box's `spring_vectors` (unwrapped
    coordinates in a periodic box at rest, exact at any spring length), else the
    minimum-image ones (thesis eq. 3.4), right while springs are shorter than half
    the box.  A chain longer than the box is reconstructed as it lies in the
    infinite periodic bulk.

    Args:
        box: the (bound) box.
        positions: (N, 3) wrapped positions.
        block: the chains.
        image: (N, 3) int image counters, or None.
    Returns:
        (C, M, 3) chain coordinates.
    """
    beads = block.take(positions)
    separation = beads[:, 1:] - beads[:, :-1]
    if image is None:
        springs = box.minimum_image_vectors(separation)
    else:
        counters = block.take(image)
        springs, _ = box.spring_vectors(separation, counters[:, 1:] - counters[:, :-1])
    return jnp.concatenate([beads[:, :1], beads[:, :1] + jnp.cumsum(springs, axis=1)], axis=1)
