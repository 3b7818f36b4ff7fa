"""Per-step conformation samples of polymer chains (the "conformation" observable).

For each chain block (species) the step records, averaged over its chains:
    <species>/bond_length_sq      ⟨Q²⟩ over all springs          (thesis eq. 4.8 for
                                                                  FENE dumbbells)
    <species>/end_to_end_sq       ⟨R_e²⟩, R_e = r_M − r_1         (chains of M > 2)
    <species>/gyration_radius_sq  ⟨R_g²⟩ = ⟨(1/M) Σ_k (r_k − r_cm)²⟩  (M > 2)
    <species>/fractional_extension ⟨|R_e|⟩/((M − 1) Q_0)           (finitely extensible
                                                                  springs; thesis
                                                                  ch. 5, "Extension")
Chains are reconstructed in one piece across periodic boundaries (thesis §3.2.4).
`ideal_references` gives the values these would take without pair forces.
"""

import jax.numpy as jnp

from jaxdpd.observables.conformation import (
    bond_vectors,
    end_to_end_squared,
    fractional_extension,
    gyration_radius_squared,
)
from jaxdpd.topology import chain_coordinates


def conformation_samples(box, positions, blocks) -> dict:
    """The per-step conformation scalars of every block (traced, inside the scan).

    Args:
        box: the periodic box.
        positions: (N, 3) wrapped positions.
        blocks: the scene's ChainBlocks.
    Returns:
        name → scalar, names as in the module docstring.
    """
    samples = {}
    for block in blocks:
        chains = chain_coordinates(box, positions, block)
        springs = bond_vectors(chains)
        samples[f"{block.species}/bond_length_sq"] = jnp.mean(jnp.sum(springs**2, axis=-1))
        if block.beads > 2:
            samples[f"{block.species}/end_to_end_sq"] = jnp.mean(end_to_end_squared(chains))
            samples[f"{block.species}/gyration_radius_sq"] = jnp.mean(
                gyration_radius_squared(chains)
            )
        if block.law.max_extension is not None:
            contour_length = (block.beads - 1) * block.law.max_extension
            samples[f"{block.species}/fractional_extension"] = jnp.mean(
                fractional_extension(chains, contour_length)
            )
    return samples


def ideal_references(blocks, kT: float) -> dict:
    """Exact values of the conformation series for chains without pair forces.

    FENE springs: ⟨Q²⟩ = 3 Q0²/(b + 5), b = H Q0²/k_BT (thesis eq. 4.8, exact for one
    spring); Hookean chains of M beads, l² = 3 k_BT/H: ⟨Q²⟩ = l², ⟨R_e²⟩ = (M − 1) l²,
    ⟨R_g²⟩ = l² (M² − 1)/(6M) (Doi & Edwards 1986, §2.1).  Other laws have none here.

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
        if block.law.name == "hookean":
            l_sq = 3 * kT / parameters["spring_constant"]
            m = block.beads
            references[f"{block.species}/bond_length_sq"] = l_sq
            if m > 2:
                references[f"{block.species}/end_to_end_sq"] = (m - 1) * l_sq
                references[f"{block.species}/gyration_radius_sq"] = l_sq * (m * m - 1) / (6 * m)
    return references
