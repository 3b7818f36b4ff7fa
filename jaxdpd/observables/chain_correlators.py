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
    <species>/positional_acf  ⟨u_i(t0) · u_i(t0 + t)⟩ per bead, u_i = r_i − r_cm
                            (autocorrelation mode); its mean over beads is
                            ⟨R_g²⟩ at lag 0, and `positional_autocorrelation`
                            turns it into the normalised C(t) of the Rouse–Zimm fit

(definitions: :mod:`jaxdpd.analysis.dynamics`; units r_c², lag times in time
units).  All work for any number of chains, one included.  The correlators live in
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

from jaxdpd.analysis.conformation import end_to_end_vector
from jaxdpd.analysis.dynamics import (
    diffusion_coefficient,
    displacement_samples,
    normalized_correlation,
)
from jaxdpd.observables import correlator
from jaxdpd.observables.component import Observable, Setting
from jaxdpd.validation import SceneError

MSD_SERIES = ("g1", "g2", "g3")
SERIES = (*MSD_SERIES, "end_to_end_acf", "positional_acf")


def _samples(box, positions, image, block) -> dict:
    """The block's correlator inputs at one time: name → (C, [M,] 3) array (`box`
    bound to the state's box state)."""
    chains = block.take(box.unwrap(positions, image))
    samples = displacement_samples(chains)
    samples["end_to_end_acf"] = end_to_end_vector(chains)
    samples["positional_acf"] = samples["g2"]
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
        correlators: from the state's `observers`: one replica's, or a batch's from
            jaxdpd.run.ensemble (every leaf with a leading replica axis B).
        sample_interval: simulated time between samples (correlator_every · Δt).
    Returns:
        dict "<species>/<series>" → (lag times (K,), values (K, C) for g3 and
        end_to_end_acf, (K, C, M) for g1, g2 and positional_acf) NumPy arrays; NaN
        at lags no sample pair has reached yet.  A batch's replicas are independent
        chains of one species, so they are merged into the chain axis, replica by
        replica (C = B · chains per replica).  Average over the chain (and bead) axes
        for the ensemble mean; keep them for error bars (e.g.
        dynamics.diffusion_coefficient, positional_autocorrelation).
    """
    results = {}
    for key, state in correlators.items():
        if state.counts.ndim == 2:
            lags, values = correlator.result(state)
        else:
            levels, points = state.buffer.shape[1:3]  # (B, L, p, ...)
            lags = correlator.lags(levels, points, state.averaging)
            batched = jax.vmap(lambda s: correlator.result(s)[1])(state)  # (B, K, C, ...)
            values = jnp.moveaxis(batched, 0, 1)
            values = values.reshape(values.shape[:1] + (-1,) + values.shape[3:])
        results[key] = (lags * sample_interval, np.asarray(jax.device_get(values)).sum(axis=-1))
    return results


def sample_every(step, every: int, correlators: dict, update):
    """`update(correlators)` at steps that are multiples of `every`, else unchanged."""
    return jax.lax.cond(jnp.equal(step % every, 0), update, lambda c: c, correlators)


def positional_autocorrelation(correlations: dict) -> dict:
    """Normalised positional autocorrelation C(t) of each block, with its error.

    C(t) = Σ_c Σ_i ⟨u_i(t0 + t) · u_i(t0)⟩ / (the same at t = 0), the quantity of
    dynamics.positional_autocorrelation (here from the on-device correlator, so
    exact at the level-0 lags and block-averaged beyond, see correlator) and of the
    Rouse–Zimm model fits.rouse_zimm_correlation.

    Args:
        correlations: from `chain_correlations`.
    Returns:
        dict "<species>/C" → (lag times (K,), C (K,), standard error (K,): jackknife
        over the chains, NaN for a single chain, see dynamics.normalized_correlation)
        NumPy arrays; NaN at lags not reached yet.  For one chain per replica, fit
        the replicas' curves together (fits.fit_rouse_zimm with a block axis) for an
        error bar.
    """
    results = {}
    for key, (lag_times, per_bead) in correlations.items():
        species, series = key.rsplit("/", 1)
        if series == "positional_acf":
            correlation, error = normalized_correlation(per_bead.sum(axis=-1))
            results[f"{species}/C"] = (lag_times, np.asarray(correlation), np.asarray(error))
    return results


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


class Dynamics(Observable):
    """Chain mean-square displacements and autocorrelations, accumulated on device in
    SimState.observers every output.correlator_every steps (module docstring)."""

    name = "dynamics"
    settings = (
        Setting("correlator_every", 10, minimum=1, integer=True),
        Setting("correlator_levels", 12, minimum=1, maximum=30, integer=True),
    )
    needs_polymers = True
    accumulates = True
    # MSDs and ⟨R(t0) · R(t0 + t)⟩: squared lengths (written to /averages).
    units = dict.fromkeys(SERIES, "r_c^2")

    def check(self, scene):
        if scene.flow is not None and scene.flow.kind == "planar_elongation":
            raise SceneError(
                "output.observables",
                "'dynamics' (mean-square displacements) needs a box at rest or in shear "
                "(Kraynik–Reinelt positions cannot be unwrapped); under elongation, "
                "measure the chains with 'conformation'",
            )

    def memory(self, scene, itemsize):
        """Two blocked correlators of 16 lags per level for each bead's 3 coordinates."""
        chain_species = {polymer.species for polymer in scene.polymers}
        beads = sum(s.count for s in scene.particles.species if s.name in chain_species)
        levels = scene.output.correlator_levels
        return {"output.correlator_levels": 2 * 16 * levels * beads * 3 * itemsize}

    def sampler(self, context):
        box, blocks, every = context.box, context.blocks, context.scene.output.correlator_every

        def sample(previous, state):
            bound_box = box.bind(state.box_state)
            observers = sample_every(
                state.step,
                every,
                state.observers,
                lambda c: update_chain_correlators(
                    c, bound_box, state.positions, state.image, blocks
                ),
            )
            return state.set(observers=observers), {}

        return sample

    def initial_accumulators(self, context, bound_box, positions, image):
        levels = context.scene.output.correlator_levels
        return init_chain_correlators(bound_box, positions, image, context.blocks, levels)
