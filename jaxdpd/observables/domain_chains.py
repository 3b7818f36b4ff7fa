"""Chain conformation of a decomposed system, from one device's rows (traced).

In a decomposed run (jaxdpd.decomposition) a chain's beads live on several devices,
and a device holds rows in no chain order.  The "conformation" samples are sums over
springs, chains and beads, so each device adds the terms of its owned rows and the
devices' sums are added (`Ownership.across_devices`):

- a spring Q_k = r_{k+1} − r_k is counted by the owner of bead k, which holds bead
  k + 1 too (a copy within the halo: the force step needs it), found by identity;
- a bead's coordinate in its chain, x_i = r_i − r_a unwrapped, is read against the
  chain's middle bead a = ⌊(M − 1)/2⌋, whose wrapped position and image counters
  every device gets from one sum over the devices (only its owner adds a nonzero
  term), as the box's `spring_vectors` of (r_i − r_a, n_i − n_a): through the
  image counters in a box at rest (exact at any length), by minimum image in a
  flowing box.  The minimum image is right for every bead exactly when
  x_{k+1} − x_k = Q_k for every spring (by induction from x_a = 0: a wrong image
  differs by a lattice vector, longer than 2 r_c in any box a scene accepts), which
  each spring's owner checks; where it fails (a bead more than half the box from
  its chain's middle bead) the chain-size samples of that block are NaN for that
  step;
- the centre of mass and R_e = x_M − x_1 follow from a second sum per chain, then
  R_g² = (1/M) Σ_i |x_i − x_cm|² from owned beads.

The samples are those of `chain_series.conformation_samples`, with the same names,
equal to them up to the order of summation.  Per step a block sends 6 numbers per
chain (middle bead) and 6 per chain (centre of mass, R_e) through the collectives,
and a few tensors.
"""

from dataclasses import dataclass

import jax
import jax.numpy as jnp

from jaxdpd.dyadic import dyadic_square


@dataclass(frozen=True)
class BlockRows:
    """One chain block's beads among a device's rows.

    Attributes:
        chain: (R,) chain index of each row holding a bead of the block, C elsewhere.
        bead: (R,) bead index in its chain (meaningless where chain = C).
        counted: (R,) bool, rows of the block's beads the device owns.
        springs: (R, 3) spring Q_k to the next bead of each counted row that has
            one, zero elsewhere.
        has_spring: (R,) bool, where `springs` holds a spring.
        partner: (R,) row of the next bead.
    """

    chain: jnp.ndarray
    bead: jnp.ndarray
    counted: jnp.ndarray
    springs: jnp.ndarray
    has_spring: jnp.ndarray
    partner: jnp.ndarray


def block_rows(bound_box, state, ownership, block) -> BlockRows:
    """The rows of `block` on one device and the springs its owned beads begin.

    Args:
        bound_box: the box at this step.
        state: the device's stepped SimState.
        ownership: its `Ownership`, with the rows' identities and `row_of`.
        block: a ChainBlock.
    """
    ids, positions, image = ownership.identities, state.positions, state.image
    index = ids - block.first
    member = (ids >= block.first) & (ids < block.stop)
    chain = jnp.where(member, index // block.beads, block.n_chains)
    bead = index % block.beads
    counted = member & ownership.owned
    partner = ownership.row_of(ids + 1)
    has_spring = counted & (bead < block.beads - 1)
    springs, _ = bound_box.spring_vectors(positions[partner] - positions, image[partner] - image)
    springs = jnp.where(has_spring[:, None], springs, 0)
    return BlockRows(chain, bead, counted, springs, has_spring, partner)


def _per_chain(values, chain, n_chains: int):
    """Σ of per-row `values` (R, ...) into their chains (C, ...); rows with chain
    index C are dropped."""
    return jax.ops.segment_sum(values, chain, n_chains)


def _mask(values, where):
    return jnp.where(where.reshape(where.shape + (1,) * (values.ndim - 1)), values, 0)


def domain_conformation_samples(bound_box, state, ownership, block, rows, law, cutoff) -> dict:
    """The "conformation" samples of one block (`chain_series.conformation_samples`)
    of a decomposed system, from one device's rows (module docstring).

    Args:
        bound_box: the box at this step.
        state: the device's stepped SimState (owned rows, halo copies, free rows).
        ownership: its `Ownership`.
        block: the ChainBlock; rows: its `block_rows`.
        law: its bond law with the state's parameters.
        cutoff: r_c (the lattice vectors of an accepted box are longer than 2 r_c).
    Returns:
        name → scalar or (3, 3) tensor, as on one device.
    """
    positions, image, total = state.positions, state.image, ownership.across_devices
    n_chains, beads, name = block.n_chains, block.beads, block.species
    chain, bead, counted = rows.chain, rows.bead, rows.counted
    middle = counted & (bead == (beads - 1) // 2)
    anchor_position, anchor_image = total(
        (
            _per_chain(_mask(positions, middle), chain, n_chains),
            _per_chain(_mask(image, middle), chain, n_chains),
        )
    )
    # Every row of the block (owned or a copy) read against its chain's middle bead.
    index = jnp.minimum(chain, n_chains - 1)
    offsets, _ = bound_box.spring_vectors(
        positions - anchor_position[index], image - anchor_image[index]
    )
    mismatch = offsets[rows.partner] - offsets - rows.springs
    wrong = rows.has_spring & (jnp.sum(mismatch * mismatch, axis=-1) > (0.5 * cutoff) ** 2)
    offsets = _mask(offsets, counted)
    ends = _mask(offsets, counted & (bead == beads - 1)) - _mask(offsets, counted & (bead == 0))
    sums = total(
        {
            "centres": _per_chain(offsets, chain, n_chains),
            "ends": _per_chain(ends, chain, n_chains),
            "bond_conformation": dyadic_square(rows.springs),
            "wrong": jnp.sum(wrong, dtype=jnp.int32),
        }
    )
    centres = sums["centres"] / beads
    ends = sums["ends"]  # (C, 3), R_e of every chain
    spread = _mask(offsets - centres[index], counted)
    size = jnp.where(sums["wrong"] == 0, 1, jnp.nan).astype(positions.dtype)
    bond_conformation = sums["bond_conformation"] / (n_chains * (beads - 1))
    end_to_end = dyadic_square(ends) * size / n_chains
    samples = {
        f"{name}/bond_length_sq": jnp.trace(bond_conformation),
        f"{name}/bond_conformation": bond_conformation,
    }
    if law.max_extension is not None:
        contour = (beads - 1) * law.max_extension
        end_length = jnp.sum(jnp.sqrt(jnp.sum(ends * ends, axis=-1)))
        samples[f"{name}/fractional_extension"] = end_length * size / (n_chains * contour)
        samples[f"{name}/fractional_extension_sq"] = jnp.trace(end_to_end) / contour**2
    if beads > 2:
        samples[f"{name}/end_to_end_sq"] = jnp.trace(end_to_end)
        samples[f"{name}/end_to_end_conformation"] = end_to_end
    gyration = total(jnp.sum(spread * spread)) / (n_chains * beads)
    samples[f"{name}/gyration_radius_sq"] = gyration * size
    return samples
