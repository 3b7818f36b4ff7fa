"""Spring pair distribution and spring crossings (the "spring_pairs" observable).

Per step (thesis §5.2.2, "Spring Pair Distribution Function", fig. 5-5):
    spring_pairs/histogram   (bins,) number of spring pairs (sharing no bead) whose
                             closest approach D falls in each of `bins` equal bins on
                             [0, D_max)
    spring_pairs/crossings   number of spring pairs that passed through each other
                             during the step: their closest-approach vector D
                             reversed (D_before · D_after < 0) while the closest
                             points lay inside both springs (|t1|, |t2| < ½) before
                             and after.  Springs crossing end-on (a closest point at
                             an end) are not counted: their D may reverse without a
                             crossing.

Pairs are taken from the spring-pair list (jaxdpd.geometry.neighbors.spring_pair_list), which is
complete up to D_max; a pair that crosses in one step is within D_max at its end as
long as the step moves beads by less than D_max.
"""

import jax.numpy as jnp
import numpy as np

from jaxdpd.forces.spring_repulsion import SpringPairGeometry
from jaxdpd.observables.component import Observable, Setting


def _inside(approach):
    return (jnp.abs(approach.t1) < 0.5) & (jnp.abs(approach.t2) < 0.5)


def spring_pair_samples(
    before: SpringPairGeometry,
    after: SpringPairGeometry,
    max_distance: float,
    bins: int,
    dtype,
) -> dict:
    """The per-step samples of the module docstring (traced, inside the scan).

    Args:
        before: the listed pairs measured at the start of the step.
        after: the same list slots measured at its end.
        max_distance: D_max (units of r_c).
        bins: number of histogram bins.
        dtype: floating dtype of the samples.
    Returns:
        {"spring_pairs/histogram": (bins,), "spring_pairs/crossings": scalar}.
    """
    distance = after.approach.distance
    counted = after.active & (distance < max_distance)
    index = jnp.floor(distance * (bins / max_distance)).astype(jnp.int32)
    index = jnp.where(counted, jnp.minimum(index, bins - 1), bins)
    histogram = jnp.zeros(bins + 1, dtype).at[index].add(1)[:bins]
    reversed_ = jnp.sum(before.approach.vector * after.approach.vector, axis=-1) < 0
    crossed = before.active & after.active & _inside(before.approach) & _inside(after.approach)
    crossings = jnp.sum(crossed & reversed_).astype(dtype)
    return {"spring_pairs/histogram": histogram, "spring_pairs/crossings": crossings}


def spring_pair_distribution(mean_histogram, max_distance: float, n_springs: int):
    """Normalised spring pair distribution n(D) = 2 ⟨h_k⟩ / (S ΔD): the mean number of
    other springs (sharing no bead) per spring and per unit closest-approach distance.

    Args:
        mean_histogram: (bins,) the time-averaged "spring_pairs/histogram".
        max_distance: D_max of the histogram.
        n_springs: S, the number of springs.
    Returns:
        (bin centres, n(D)) as NumPy arrays.
    """
    mean_histogram = np.asarray(mean_histogram, np.float64)
    bins = mean_histogram.shape[0]
    width = max_distance / bins
    centres = (np.arange(bins) + 0.5) * width
    return centres, 2 * mean_histogram / (n_springs * width)


class SpringPairs(Observable):
    """Per-step histogram of spring closest approaches below output.spring_pair_max
    and the count of spring crossings (read from the spring-pair list)."""

    name = "spring_pairs"
    settings = (
        Setting("spring_pair_bins", 50, minimum=1, integer=True),
        Setting("spring_pair_max", lambda cutoff: cutoff / 3, minimum=0, exclusive_minimum=True),
    )
    needs_polymers = True
    units = {"spring_pairs/": "1"}  # histogram and crossings: counts

    def memory(self, scene, itemsize):
        return {
            "output.spring_pair_bins": scene.run.chunk * scene.output.spring_pair_bins * itemsize
        }

    def sampler(self, context):
        search, dtype = context.spring_search, context.dtype
        output = context.scene.output

        def sample(previous, state):
            # The same list slots at both ends of the step: crossings are reversals.
            before = search.measure(previous.positions, state.spring_pairs, previous.box_state)
            after = search.measure(state.positions, state.spring_pairs, state.box_state)
            return state, spring_pair_samples(
                before, after, output.spring_pair_max, output.spring_pair_bins, dtype
            )

        return sample
