"""Radial distribution function g(r), sampled at chunk ends.

    g(r_k) = h_k / [½ N (N − 1) V_k / V],

with h_k the number of pairs whose minimum-image distance falls in shell k of volume
V_k = (4π/3)(r_{k+1}³ − r_k³): an ideal gas gives g = 1 exactly in expectation.
Pairs are found with the cell list (cut-off r_max, no skin), reallocated when a
configuration needs more room.  A fixed list of all pairs is used instead where some
axis holds a single cell, or where no axis has more than three: there every cell
neighbours every other, so the cell list would test all pairs anyway, and the fixed
list runs as fast and compiles in a fraction of the time.
"""

from functools import partial

import jax
import jax.numpy as jnp
import numpy as np

from jaxdpd.forces.pair_sums import pair_geometry
from jaxdpd.geometry.boxes import make_box
from jaxdpd.geometry.neighbors import PairList, neighbor_search
from jaxdpd.geometry.neighbors.cell_list import cell_grid
from jaxdpd.observables.component import Observable, Setting
from jaxdpd.scatter import segment_sum_where
from jaxdpd.validation import SceneError


class RadialDistribution:
    """Accumulates pair-distance histograms over sampled configurations.

    Args:
        box: the static box (r_max must be < half its thinnest cell height).
        n_particles: N.
        r_max: largest distance histogrammed.
        bins: number of equal-width shells on [0, r_max).
    """

    def __init__(self, box, n_particles: int, r_max: float, bins: int):
        self.box, self.n_particles, self.r_max, self.bins = box, n_particles, r_max, bins
        grid = cell_grid(box, r_max, n_particles)
        self._all_pairs = min(grid) < 3 or max(grid) <= 3
        self._search = None if self._all_pairs else neighbor_search(box, n_particles, r_max, 0.0)
        self._pairs = None
        self.counts = np.zeros(bins, np.int64)
        self.samples = 0

    def _every_pair(self, positions) -> PairList:
        """All pairs i < j as a fixed list (few cells: see the module docstring)."""
        n = self.n_particles
        i, j = np.triu_indices(n, 1)
        zero = jnp.asarray(0, jnp.int32)
        return PairList(
            jnp.asarray(i, jnp.int32),
            jnp.asarray(j, jnp.int32),
            positions,
            None,
            zero,
            zero,
            jnp.asarray(False),
            zero,
        )

    @partial(jax.jit, static_argnums=0)
    def _histogram(self, positions, pair_list, box_state):
        if not self._all_pairs:
            pair_list = self._search.update(positions, pair_list, box_state)
        bound_box = self.box.bind(box_state)
        geometry = pair_geometry(bound_box, positions, pair_list, self.r_max, half=True)
        shell = jnp.floor(geometry.distance * (self.bins / self.r_max)).astype(jnp.int32)
        ones = geometry.within.astype(jnp.int32)
        counts = segment_sum_where(ones, shell, geometry.within, self.bins)
        return counts, pair_list

    def sample(self, positions, box_state=None) -> None:
        """Add one configuration (N, 3) to the histogram (`box_state`: that of a
        flowing box, None at rest)."""
        if self._pairs is None:
            if self._all_pairs:
                self._pairs = self._every_pair(positions)
            else:
                self._pairs = self._search.allocate(positions, 1.5, box_state=box_state)
        counts, pairs = self._histogram(positions, self._pairs, box_state)
        if bool(pairs.overflow):
            needs = (int(pairs.needed_pairs), int(pairs.needed_cell_occupancy))
            self._pairs = self._search.allocate(positions, 1.5, minimum=needs, box_state=box_state)
            counts, pairs = self._histogram(positions, self._pairs, box_state)
        self.counts += np.asarray(counts)
        self.samples += 1

    def observe(self, state) -> None:
        """Add the configuration of a SimState at a chunk end."""
        self.sample(state.positions, state.box_state)

    def extras(self) -> dict:
        """The histogram, stored with a checkpoint."""
        return {"rdf_counts": self.counts, "rdf_samples": np.asarray(self.samples)}

    def restore(self, extras: dict) -> None:
        """The histogram from a checkpoint's `extras`."""
        self.counts = np.array(extras["rdf_counts"], np.int64)
        self.samples = int(extras["rdf_samples"])

    def write(self, writer) -> None:
        """g(r) to /averages/rdf of an H5MDWriter (nothing before any sample)."""
        if self.samples:
            writer.write_rdf(*self.result(), self.samples)

    def result(self):
        """(shell centres r, g(r)) as NumPy arrays (NaN before any sample)."""
        edges = np.linspace(0.0, self.r_max, self.bins + 1)
        centres = 0.5 * (edges[1:] + edges[:-1])
        shell_volume = 4.0 / 3.0 * np.pi * (edges[1:] ** 3 - edges[:-1] ** 3)
        n = self.n_particles
        expected = 0.5 * n * (n - 1) * shell_volume / self.box.volume * self.samples
        with np.errstate(invalid="ignore", divide="ignore"):
            return centres, self.counts / expected


class Rdf(Observable):
    """g(r), histogrammed on the host at chunk ends (`RadialDistribution`) and written
    to /averages/rdf: no per-step sample.  A decomposed run's state gives its
    particles in scene order (`DecomposedState.positions`), so g(r) is histogrammed
    from the whole configuration there too (docs/scaling_out.md: what it costs)."""

    name = "rdf"
    decomposes = True
    settings = (
        Setting("rdf_bins", 100, minimum=1, integer=True),
        Setting("rdf_max", 3.0, minimum=0, exclusive_minimum=True),
    )

    def domain_sampler(self, context):
        return None

    def chunk_accumulator(self, simulation):
        output = simulation.scene.output
        return RadialDistribution(
            simulation.box, simulation.scene.n_particles, output.rdf_max, output.rdf_bins
        )

    def example_scene(self, precision="float64") -> dict:
        """The example fluid with g(r) up to 2 r_c (less than half its 4.64 edge)."""
        data = super().example_scene(precision)
        data["output"]["rdf_max"] = 2.0
        return data

    def memory(self, scene, itemsize):
        return {"output.rdf_bins": 12 * scene.output.rdf_bins}  # histogram and edges

    def check(self, scene):
        heights = make_box(scene.box.kind, scene.box.lengths, scene.flow).cell_heights
        rdf_max = scene.output.rdf_max
        if not rdf_max < min(heights) / 2:
            raise SceneError(
                "output.rdf_max",
                f"{rdf_max} must be < half the box's thinnest extent ({min(heights) / 2:.4g}; "
                "the shortest edge, or a sheared box's tilted height)",
            )
