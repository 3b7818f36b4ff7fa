"""On-device time correlations of polymer chains while a run goes (the "dynamics"
observable).

For each chain block (species) a multiple-tau correlator
(:mod:`jaxdpd.observables.correlator`) is fed every `output.correlator_every` steps
with the unwrapped chain coordinates (thesis §3.2.4–3.2.5), so no trajectory is kept:

    <species>/g1            bead mean-square displacement         (msd mode)
    <species>/g2            bead MSD relative to the chain's centre of mass
    <species>/g3            centre-of-mass mean-square displacement
    <species>/end_to_end_acf  ⟨R_e(t0) · R_e(t0 + t)⟩, R_e = r_M − r_1 (its decay gives
                            the longest relaxation time; for dumbbells R_e = Q)

(definitions: :mod:`jaxdpd.observables.dynamics`).  The correlators live in
`SimState.observers`, so they are checkpointed with the state and cost memory
O(levels · 16 · beads) whatever the run length.

In a Lees–Edwards box the coordinates are unwrapped through the sheared lattice
(`BoundLeesEdwards.unwrap`), the laboratory-frame path of each particle, so the x
part of each MSD holds the flow besides diffusion (a Brownian particle starting at
height y0 from the stagnation plane has ⟨Δx²⟩ = 2Dt + γ̇² y0² t² + (2/3) γ̇² D t³;
Katayama & Terauti, Eur. J. Phys. 17, 136 (1996)); the y and z parts are
unaffected.  The run summary therefore reports no D_CM under shear.  The same MSDs
follow from the file's frames through `jaxdpd.io.reader.read_unwrapped_positions`.
"""

import jax
import jax.numpy as jnp
import numpy as np

from jaxdpd.observables import correlator
from jaxdpd.observables.conformation import end_to_end_vector
from jaxdpd.observables.dynamics import diffusion_coefficient, displacement_samples

MSD_SERIES = ("g1", "g2", "g3")
SERIES = (*MSD_SERIES, "end_to_end_acf")


def _samples(box, positions, image, block) -> dict:
    """The block's correlator inputs at one time: name → (C, [M,] 3) array (`box`
    bound to the state's box state)."""
    chains = block.take(box.unwrap(positions, image))
    samples = displacement_samples(chains)
    samples["end_to_end_acf"] = end_to_end_vector(chains)
    return samples


def init_chain_correlators(box, positions, image, blocks, levels: int) -> dict:
    """Empty correlators for every block and series (host side, outside jit).

    Args:
        box: the simulation box bound to the state's box state.
        positions, image: (N, 3) a state's wrapped positions and image counters.
        blocks: the scene's ChainBlocks.
        levels: multiple-tau levels; the longest lag is 15 · 2^(levels − 1) samples.
    Returns:
        dict "<species>/<series>" → MultipleTauState.
    """
    correlators = {}
    for block in blocks:
        for name, sample in _samples(box, positions, image, block).items():
            mode = "msd" if name in MSD_SERIES else "autocorrelation"
            correlators[f"{block.species}/{name}"] = correlator.init(
                sample.shape, levels, mode=mode, dtype=positions.dtype
            )
    return correlators


def update_chain_correlators(correlators: dict, box, positions, image, blocks) -> dict:
    """Feed one sample of every block into its correlators (traced, inside the scan)."""
    updated = {}
    for block in blocks:
        for name, sample in _samples(box, positions, image, block).items():
            key = f"{block.species}/{name}"
            updated[key] = correlator.update(correlators[key], sample)
    return updated


def chain_correlations(correlators: dict, sample_interval: float) -> dict:
    """Lag times and correlations per chain (or bead), summed over x, y, z (host side).

    Args:
        correlators: from the state's `observers`.
        sample_interval: simulated time between samples (correlator_every · Δt).
    Returns:
        dict "<species>/<series>" → (lag times (K,), values (K, C) for g3 and
        end_to_end_acf, (K, C, M) for g1 and g2) NumPy arrays; NaN at lags no sample
        pair has reached yet.  Average over the chain (and bead) axes for the
        ensemble mean; keep them for error bars (e.g. dynamics.diffusion_coefficient).
    """
    results = {}
    for key, state in correlators.items():
        lags, values = correlator.result(state)
        results[key] = (lags * sample_interval, np.asarray(jax.device_get(values)).sum(axis=-1))
    return results


def sample_every(step, every: int, correlators: dict, update):
    """`update(correlators)` at steps that are multiples of `every`, else unchanged."""
    return jax.lax.cond(jnp.equal(step % every, 0), update, lambda c: c, correlators)


def center_of_mass_diffusion(correlations: dict, fit_fraction: float = 0.25) -> dict:
    """D_CM of each block from the long-time slope of its g3 (thesis eq. 3.7).

    The fit uses the lags from `fit_fraction` of the longest lag reached on; that
    lag must exceed the chains' longest relaxation time for the estimate to mean
    anything (short runs of long chains: read g3 instead).

    Args:
        correlations: from `chain_correlations`.
    Returns:
        dict "<species>/D_CM" → (D, standard error from the chains, see
        dynamics.diffusion_coefficient), for blocks with at least two chains and
        enough lags.
    """
    estimates = {}
    for key, (lag_times, per_chain) in correlations.items():
        species, series = key.rsplit("/", 1)
        reached = np.all(np.isfinite(per_chain), axis=1)
        if series != "g3" or per_chain.shape[1] < 2 or reached.sum() < 8:
            continue
        times = lag_times[reached]
        estimates[f"{species}/D_CM"] = diffusion_coefficient(
            times, per_chain[reached], fit_from=fit_fraction * times[-1]
        )
    return estimates
