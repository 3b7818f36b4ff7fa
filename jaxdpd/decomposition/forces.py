"""The force kernel of one device: pair terms over its slab and halos, bonds found by
particle identity, the body force.

It has the signature of jaxdpd.engine.build.force_kernel's kernel, so a solvent's
own step (jaxdpd.solvents) runs unchanged on a device's rows.  What differs from one
device holding everything: rows are not particle indices, so the pair noise is keyed
by identities (`PairGeometry.identities`) and a bead's chain neighbours are looked
up by identity among the rows present; each device counts the share of the virial
its owned rows carry (half of a pair with a halo particle, a bond by the owner of
its first bead), so the shares sum to the system's virial over the devices.
"""

import jax.numpy as jnp

from jaxdpd.decomposition.slab_view import SlabState
from jaxdpd.dyadic import dyadic_sum
from jaxdpd.engine import errors
from jaxdpd.engine.build import pair_term_parts
from jaxdpd.forces.pair_sums import pair_geometry, pair_sums


def identity_lookup(ids):
    """`row_of(wanted) -> (row, present)`: the row holding each identity of `wanted`
    (any row where absent) and whether it is there; the rows are sorted by identity
    once."""
    absent = jnp.iinfo(jnp.int32).max
    keys = jnp.where(ids >= 0, ids, absent)  # free rows last, and sorted
    order = jnp.argsort(keys)
    ordered = keys[order]

    def row_of(wanted):
        place = jnp.minimum(jnp.searchsorted(ordered, wanted), ids.shape[0] - 1)
        return order[place], ordered[place] == wanted

    return row_of


def chain_bond_forces_by_identity(bound_box, positions, ids, row_of, owned, block, law, halo):
    """Spring forces on every row of one chain block's beads, partners found by identity.

    Args:
        bound_box: the whole box at this instant (minimum-image spring vectors).
        positions: (R, 3) wrapped positions of the device's rows.
        ids: (R,) identities (−1: free row).
        row_of: `identity_lookup(ids)`.
        owned: (R,) bool, rows the device owns.
        block: the ChainBlock (beads first … stop − 1, chain after chain).
        law: its bond law, parameters bound.
        halo: the halo width: an owned bead's partner is present only within it.
    Returns:
        ((R, 3) forces, (3, 3) virial of the springs whose first bead is owned, bool:
        a spring of an owned bead past the halo or its partner absent, bool: a FENE
        spring at or past its maximum extension).
    """
    in_block = (ids >= block.first) & (ids < block.stop)
    bead = (ids - block.first) % block.beads
    springs, pulls, lost, stretched = [], [], False, False
    for step, has in ((1, bead < block.beads - 1), (-1, bead > 0)):
        has = in_block & has
        partner, found = row_of(ids + step)
        live = has & found
        # Spring vector from the lower bead to the upper one, Q = r_{k+1} − r_k.
        separation = (positions[partner] - positions) * step
        spring = jnp.where(live[:, None], bound_box.minimum_image_vectors(separation), 0)
        q_sq = jnp.sum(spring * spring, axis=-1)
        springs.append(spring)
        pulls.append(jnp.where(live[:, None], law.stiffness(q_sq)[:, None] * spring, 0))
        lost = lost | jnp.any(owned & has & (~found | (q_sq >= halo * halo)))
        if law.max_extension is not None:
            stretched = stretched | jnp.any(owned & live & (q_sq >= law.max_extension**2))
    forces = pulls[0] - pulls[1]
    virial = -dyadic_sum(owned[:, None] * springs[0], pulls[0])
    return forces, virial, lost, jnp.asarray(stretched)


def domain_force_kernel(box, search, terms, blocks, cutoff, with_virial, body_force, halo):
    """`kernel(rows_ids, owned, origin, row_of) -> interactions` for one device's
    rows, `row_of` their `identity_lookup` (built once per step by the caller).

    Args:
        box: the whole (static) box.
        search: the cell list over the device's `SlabView`, or None without pair
            terms or thermostat.
        terms: the scene's pair terms (jaxdpd.engine.build.pair_terms).
        blocks: the chain blocks (identities as in the scene).
        cutoff: r_c of the pair terms.
        with_virial: compute the virial shares.
        body_force: `body_force(positions, amplitude)`, or None.
        halo: the halo width (bond partners are present within it).
    """

    def kernel(ids, owned, origin, row_of):
        present = ids >= 0

        def interactions(positions, velocities, state, refresh_pairs: bool = True):
            bound = box.bind(state.box_state)
            vectors, virial = jnp.zeros_like(positions), {}
            pair_list = state.pair_list
            if search is not None:
                # Free rows are absent for the cell list: it bins no non-finite row.
                listed = jnp.where(present[:, None], positions, jnp.nan)
                pair_list = search.update(listed, pair_list, SlabState(state.box_state, origin))
            if terms:
                geometry = pair_geometry(bound, positions, pair_list, cutoff, True, ids)
                parts = pair_term_parts(terms, geometry, velocities, state)
                shares = 0.5 * (owned[geometry.i].astype(positions.dtype) + owned[geometry.j])
                vectors, virial = pair_sums(geometry, parts, with_virial, shares)
            state = state.set(pair_list=pair_list)
            if body_force is not None:
                vectors = vectors + body_force(
                    positions, state.parameters["body_force"]["amplitude"]
                )
            bits = jnp.asarray(0, jnp.int32)
            for block in blocks:
                law = block.law.with_parameters(state.parameters["bond"][block.species])
                forces, bond_virial, lost, stretched = chain_bond_forces_by_identity(
                    bound, positions, ids, row_of, owned, block, law, halo
                )
                vectors = vectors + forces
                if with_virial:
                    virial["bond"] = virial.get("bond", 0) + bond_virial
                bits = (
                    bits
                    | jnp.where(lost, errors.StepError.DOMAIN_REACH, 0)
                    | jnp.where(stretched, errors.StepError.SPRING_OVERSTRETCHED, 0)
                )
            vectors = jnp.where(present[:, None], vectors, 0)
            return vectors, virial, state, bits

        return interactions

    return kernel
