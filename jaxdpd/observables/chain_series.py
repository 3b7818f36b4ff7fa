"""Per-step conformation samples of polymer chains (the "conformation" observable).

For each chain block (species) the step records, averaged over its chains:
    <species>/bond_length_sq      ⟨Q²⟩ over all springs          (thesis eq. 4.8 for
                                                                  FENE dumbbells)
    <species>/bond_conformation   (3, 3) conformation tensor ⟨Q Q⟩ over all springs
                                  (thesis eqs. 4.16–4.18: its xy and normal
                                  components under shear)
    <species>/fractional_extension      ⟨|R_e|⟩/L_c, L_c = (M − 1) Q0 the contour
    <species>/fractional_extension_sq   ⟨R_e²⟩/L_c², for finitely extensible laws
                                  (FENE, FENE-log); for dumbbells R_e = Q, so the
                                  latter is the thesis's ⟨Q²⟩/Q0² (fig. 4-10)
    <species>/end_to_end_sq       ⟨R_e²⟩, R_e = r_M − r_1         (chains of M > 2)
    <species>/end_to_end_conformation   (3, 3) ⟨R_e R_e⟩            (M > 2)
    <species>/gyration_radius_sq  ⟨R_g²⟩ = ⟨(1/M) Σ_k (r_k − r_cm)²⟩  (every M ≥ 2; a
                                  dumbbell's is exactly ⟨Q²⟩/4)
and, with "pressure" and a [pair] too (`spring_pair_pressure`):
    <species>/spring_pair_pressure  (3, 3) the soft repulsion between the two beads
                                  of every spring as a pressure tensor: the
                                  intramolecular excluded-volume stress that DPD
                                  adds to the springs' Kramers stress (thesis §4.2.6)
Chains are reconstructed in one piece across periodic boundaries (thesis §3.2.4).
`ideal_references` gives the values these would take without pair forces.
"""

import jax.numpy as jnp

from jaxdpd.analysis.conformation import (
    bond_vectors,
    conformation_tensor,
    end_to_end_squared,
    end_to_end_vector,
    fractional_extension,
    gyration_radius_squared,
)
from jaxdpd.analysis.rheology import PART_PREFIX, conformation_components
from jaxdpd.forces.pair_laws import soft_repulsion
from jaxdpd.geometry.chain_topology import chain_coordinates
from jaxdpd.observables.component import (
    Observable,
    long_enough,
    steady_shear_rate,
    summary_row,
)
from jaxdpd.observables.domain_chains import block_rows, domain_conformation_samples
from jaxdpd.observables.drag import giesekus_drag


def conformation_samples(box, positions, blocks, parameters=None, image=None) -> dict:
    """The per-step conformation samples of every block (traced, inside the scan).

    Args:
        box: the (bound) box.
        positions: (N, 3) wrapped positions.
        blocks: the scene's ChainBlocks.
        parameters: the state's traced parameters (jaxdpd.engine.parameters), whose bond
            max_extension gives the contour length; None: the scene's values.
        image: (N, 3) image counters, or None (jaxdpd.geometry.chain_topology.chain_coordinates:
            with them, springs longer than half the box are measured right).
    Returns:
        name → scalar or (3, 3) tensor, names as in the module docstring.
    """
    samples = {}
    for block in blocks:
        name = block.species
        chains = chain_coordinates(box, positions, block, image)
        springs = bond_vectors(chains)
        samples[f"{name}/bond_length_sq"] = jnp.mean(jnp.sum(springs**2, axis=-1))
        samples[f"{name}/bond_conformation"] = conformation_tensor(springs, axis=(0, 1))
        law = block.law
        if parameters is not None:
            law = law.with_parameters(parameters["bond"][name])
        if law.max_extension is not None:
            extension = fractional_extension(chains, (block.beads - 1) * law.max_extension)
            samples[f"{name}/fractional_extension"] = jnp.mean(extension)
            samples[f"{name}/fractional_extension_sq"] = jnp.mean(extension**2)
        if block.beads > 2:
            samples[f"{name}/end_to_end_sq"] = jnp.mean(end_to_end_squared(chains))
            samples[f"{name}/end_to_end_conformation"] = conformation_tensor(
                end_to_end_vector(chains)
            )
        samples[f"{name}/gyration_radius_sq"] = jnp.mean(gyration_radius_squared(chains))
    return samples


def spring_pair_pressure(box, positions, block, strength, cutoff: float, volume: float, image=None):
    """The conservative pair force across each spring of a block, as a pressure.

    (1/V) Σ_springs Q ⊗ a (1 − Q/r_c) Q/|Q| for |Q| < r_c (thesis eq. 3.46 restricted
    to the bonded pairs; positive = repulsive, as "pressure_tensor_part/conservative",
    of which it is a part).  Only the two beads a spring joins are counted, not other
    pairs of one chain.

    Args:
        box: the (bound) box.
        positions: (N, 3) wrapped positions.
        block: a ChainBlock.
        strength: a of the block's species with itself (energy/length).
        cutoff: r_c.
        volume: box volume.
        image: (N, 3) image counters, or None (as in `conformation_samples`).
    Returns:
        (3, 3) tensor (units of pressure).
    """
    springs = bond_vectors(chain_coordinates(box, positions, block, image)).reshape(-1, 3)
    along = _repulsion_along(springs, strength, cutoff)
    return jnp.einsum("k,ka,kb->ab", along, springs, springs) / volume


def _repulsion_along(springs, strength, cutoff: float):
    """(K,) a (1 − Q/r_c) / Q of each spring vector (K, 3): the repulsion across it
    per unit of its vector."""
    length = jnp.sqrt(jnp.sum(springs * springs, axis=-1))
    weight = jnp.clip(1 - length / cutoff, 0, None)
    return soft_repulsion(weight, strength) / jnp.maximum(length, jnp.finfo(length.dtype).tiny)


def ideal_references(blocks, kT: float) -> dict:
    """Exact values of the conformation series for chains without pair forces.

    FENE springs: ⟨Q²⟩ = 3 Q0²/(b + 5), b = H Q0²/k_BT (thesis eq. 4.8, exact for one
    spring; for dumbbells also ⟨Q²⟩/Q0² = 3/(b + 5)); Hookean chains of M beads,
    l² = 3 k_BT/H: ⟨Q²⟩ = l², ⟨R_e²⟩ = (M − 1) l²,
    ⟨R_g²⟩ = l² (M² − 1)/(6M) (Doi & Edwards 1986, §2.1; l²/4 for a dumbbell).  Other
    laws have none here.

    Returns:
        series name → reference value, for the series that have one.
    """
    references = {}
    for block in blocks:
        parameters = block.law.parameters
        if block.law.name == "fene":
            q0, h = parameters["max_extension"], parameters["spring_constant"]
            b = h * q0 * q0 / kT
            references[f"{block.species}/bond_length_sq"] = 3 * q0 * q0 / (b + 5)
            if block.beads == 2:
                references[f"{block.species}/fractional_extension_sq"] = 3 / (b + 5)
        if block.law.name == "hookean":
            l_sq = 3 * kT / parameters["spring_constant"]
            m = block.beads
            references[f"{block.species}/bond_length_sq"] = l_sq
            references[f"{block.species}/gyration_radius_sq"] = l_sq * (m * m - 1) / (6 * m)
            if m > 2:
                references[f"{block.species}/end_to_end_sq"] = (m - 1) * l_sq
    return references


class Conformation(Observable):
    """The per-step chain conformation samples of every block (module docstring);
    with "pressure" and a [pair], each block's spring_pair_pressure too."""

    name = "conformation"
    needs_polymers = True
    decomposes = True
    units = {
        name: "r_c^2"
        for name in (
            "bond_length_sq",
            "bond_conformation",
            "end_to_end_sq",
            "end_to_end_conformation",
            "gyration_radius_sq",
        )
    } | {
        "spring_pair_pressure": "k_BT/r_c^3",
        # ⟨|R_e|⟩/L_c and ⟨R_e²⟩/L_c²: ratios of lengths.
        "fractional_extension": "1",
        "fractional_extension_sq": "1",
    }

    @staticmethod
    def _strengths(scene, blocks) -> dict:
        """{species: a of the species with itself} of the blocks whose
        spring_pair_pressure is sampled (with "pressure" and a [pair]), else {}."""
        if "pressure" not in scene.output.observables or scene.pair is None:
            return {}
        names = scene.species_names
        return {
            block.species: scene.pair.a[names.index(block.species)][names.index(block.species)]
            for block in blocks
        }

    def sampler(self, context):
        scene, box, blocks = context.scene, context.box, context.blocks
        strengths = self._strengths(scene, blocks)

        def sample(previous, state):
            bound_box = box.bind(state.box_state)
            samples = conformation_samples(
                bound_box, state.positions, blocks, state.parameters, state.image
            )
            for block in (block for block in blocks if block.species in strengths):
                samples[f"{block.species}/spring_pair_pressure"] = spring_pair_pressure(
                    bound_box,
                    state.positions,
                    block,
                    strengths[block.species],
                    scene.cutoff,
                    scene.volume,
                    state.image,
                )
            return state, samples

        return sample

    def domain_sampler(self, context):
        """The same samples in a decomposed run (jaxdpd.observables.domain_chains)."""
        scene, box, blocks = context.scene, context.box, context.blocks
        strengths = self._strengths(scene, blocks)

        def sample(ownership, state):
            bound_box = box.bind(state.box_state)
            samples = {}
            for block in blocks:
                rows = block_rows(bound_box, state, ownership, block)
                law = block.law.with_parameters(state.parameters["bond"][block.species])
                samples.update(
                    domain_conformation_samples(
                        bound_box, state, ownership, block, rows, law, scene.cutoff
                    )
                )
                if block.species in strengths:
                    along = _repulsion_along(rows.springs, strengths[block.species], scene.cutoff)
                    along = jnp.where(rows.has_spring, along, 0)
                    stress = jnp.einsum("k,ka,kb->ab", along, rows.springs, rows.springs)
                    samples[f"{block.species}/spring_pair_pressure"] = (
                        ownership.across_devices(stress) / scene.volume
                    )
            return samples

        return sample

    def summary_rows(self, scene, series, n_blocks):
        """The sheared components of each species' ⟨QQ⟩ (`conformation_components`)
        and, for dumbbells under steady shear, the Giesekus drag coefficient
        "<species>/drag_giesekus" (jaxdpd.observables.drag, "shear" component, springs
        alone as thesis eq. 4.18) and "<species>/drag_giesekus_ev" (springs plus the
        bead repulsion across them)."""
        rows = {}
        rate = steady_shear_rate(scene)
        bond = f"{PART_PREFIX}bond"
        for polymer in scene.polymers:
            name = f"{polymer.species}/bond_conformation"
            if not long_enough(series, name, n_blocks):
                continue
            for key, estimate in conformation_components(series[name], n_blocks).items():
                rows[f"{name}_{key}"] = summary_row(estimate)
            if rate is None or polymer.beads != 2 or not long_enough(series, bond, n_blocks):
                continue
            _, springs = scene.species_range(polymer.species)
            density = springs / 2 / scene.volume
            arguments = (series[bond], series[name], rate, density, scene.solvent.kT)
            estimate = giesekus_drag(*arguments, n_blocks=n_blocks)
            rows[f"{polymer.species}/drag_giesekus"] = summary_row(estimate)
            repulsion = f"{polymer.species}/spring_pair_pressure"
            if repulsion in series:
                estimate = giesekus_drag(
                    *arguments, n_blocks=n_blocks, intramolecular_pressure=series[repulsion]
                )
                rows[f"{polymer.species}/drag_giesekus_ev"] = summary_row(estimate)
        return rows
