"""Pair geometry and accumulation of central pair quantities onto particles.

Every pair law in jaxdpd (forces, thermostat forces, impulses) is central: it acts
along the unit vector e_ij = (r_i − r_j)/r_ij with a scalar magnitude m_ij (positive
= repulsive).  `pair_geometry` measures the pairs once; `pair_sums` turns the
magnitudes of several laws into per-particle vectors Σ_j m_ij e_ij and each law's
virial Σ_pairs r_ij ⊗ m_ij e_ij (`accumulate` does the first for one law).
Components are handled as separate arrays (structure of arrays), which XLA
vectorises well on CPU.
"""

from dataclasses import dataclass

import jax
import jax.numpy as jnp

from jaxdpd.scatter import segment_sum_where


@dataclass(frozen=True)
class PairGeometry:
    """Separations of the listed pairs (traced arrays, shape (P,) each).

    Attributes:
        i, j: particle indices (clipped to valid rows; use `within` to mask).
        separation: (dx, dy, dz) of r_i − r_j, minimum image.
        distance: |r_i − r_j| (1 where not within the cut-off).
        inverse_distance: 1/distance.
        within: bool, listed and closer than the cut-off.
        weight: 1 − r/r_c within the cut-off, else 0 (the standard DPD weight).
        n_particles: N.
        half: True when each pair is listed once.
        streaming: (L r_ij)·e_ij, the flow's part of the laboratory relative velocity
            along the pair (thesis eq. 3.18), or None in a box at rest.
        identities: (N,) int32 identity of each row where rows are not the
            particles' identities (a domain's buffers, jaxdpd.decomposition), else
            None; pair noise is keyed by identities (`identity_pairs`).
    """

    i: jnp.ndarray
    j: jnp.ndarray
    separation: tuple
    distance: jnp.ndarray
    inverse_distance: jnp.ndarray
    within: jnp.ndarray
    weight: jnp.ndarray
    n_particles: int
    half: bool
    streaming: jnp.ndarray | None = None
    identities: jnp.ndarray | None = None

    def identity_pairs(self):
        """(identity of i, identity of j) of each listed pair: the particles' own
        numbers, which key the counter-based pair noise (jaxdpd.engine.noise), so a
        pair draws the same numbers wherever its rows sit."""
        if self.identities is None:
            return self.i, self.j
        return self.identities[self.i], self.identities[self.j]

    def along_pair(self, per_particle):
        """(x_i − x_j)·e_ij for a per-particle vector field x of shape (N, 3)."""
        total = 0
        for axis in range(3):
            component = per_particle[:, axis]
            total = total + (component[self.i] - component[self.j]) * self.separation[axis]
        return total * self.inverse_distance

    def relative_velocity_along_pair(self, velocities):
        """Laboratory relative velocity (v_i − v_j)·e_ij from stored (peculiar)
        velocities: c_i − c_j plus the flow's L r_ij in a flowing box (thesis eq.
        3.18).  Every velocity-dependent pair law reads its velocities here."""
        along = self.along_pair(velocities)
        return along if self.streaming is None else along + self.streaming

    def gather_pair(self, table, per_particle):
        """table[s_i, s_j] for per-particle integer labels s (e.g. species).

        Args:
            table: (S, S) array.
            per_particle: (N,) int labels.
        """
        n_labels = table.shape[0]
        return table.reshape(-1)[per_particle[self.i] * n_labels + per_particle[self.j]]


def pair_geometry(
    box, positions, pair_list, cutoff: float, half: bool, identities=None
) -> PairGeometry:
    """Measure the pairs of `pair_list` in `box`.

    Args:
        box: a bound box (`separation`, and in flow `velocity_gradient` and
            `streaming_along_pair`; see jaxdpd.geometry.boxes).
        positions: (N, 3) wrapped positions.
        pair_list: PairList with i, j (padded with N).
        cutoff: r_c; pairs at r ≥ r_c get `within = False`.
        half: whether the list holds each pair once.
        identities: (N,) particle identity of each row, or None when rows are
            identities (see PairGeometry).
    """
    n = positions.shape[0]
    listed = pair_list.i < n
    i = jnp.where(listed, pair_list.i, 0)
    j = jnp.where(listed, pair_list.j, 0)
    separation = box.separation(
        tuple(positions[:, axis][i] - positions[:, axis][j] for axis in range(3))
    )
    distance_sq = separation[0] ** 2 + separation[1] ** 2 + separation[2] ** 2
    within = listed & (distance_sq < cutoff * cutoff) & (i != j)
    safe_sq = jnp.where(within, distance_sq, jnp.ones_like(distance_sq))
    inverse = jax.lax.rsqrt(safe_sq)
    distance = safe_sq * inverse
    weight = jnp.where(within, 1 - distance * (1.0 / cutoff), jnp.zeros_like(distance))
    streaming = None
    if box.velocity_gradient is not None:
        streaming = box.streaming_along_pair(separation, inverse)
    return PairGeometry(
        i, j, separation, distance, inverse, within, weight, n, half, streaming, identities
    )


def pair_sums(geometry: PairGeometry, magnitudes: dict, with_virial: bool, virial_weights=None):
    """Per-particle sums and virials of central pair laws.

    Each law's magnitude is divided by the distance once, m_ij / r_ij: a
    division, which XLA materialises instead of re-evaluating it (noise hash
    included) inside every consumer, as it would a product with 1/r_ij.

    Args:
        geometry: from `pair_geometry`.
        magnitudes: {name: (P,) magnitudes m_ij (0 where not `within`)}.
        with_virial: also return each law's virial.
        virial_weights: (P,) share of each pair's virial that this sum counts, or
            None for all of it (a domain counts half of a pair it shares with
            another, jaxdpd.decomposition).
    Returns:
        ((N, 3) vectors Σ_j Σ_laws m_ij e_ij, {name: (3, 3) virial W_ab =
        Σ_pairs (r_i − r_j)_a m_ij e_ij,b} (thesis eq. 3.46, each pair counted
        once), or {} without `with_virial`).
    """
    scales = {name: m / geometry.distance for name, m in magnitudes.items()}
    total = sum(scales.values())
    n = geometry.n_particles
    columns = []
    for separation in geometry.separation:
        component = total * separation
        column = segment_sum_where(component, geometry.i, geometry.within, n)
        if geometry.half:
            column = column - segment_sum_where(component, geometry.j, geometry.within, n)
        columns.append(column)
    virials = {}
    if with_virial:
        count = 1.0 if geometry.half else 0.5  # a full list sees every pair twice
        for name, scale in scales.items():
            if virial_weights is not None:
                scale = scale * virial_weights
            virials[name] = count * jnp.stack(
                [
                    jnp.stack([jnp.sum(sa * scale * sb) for sb in geometry.separation])
                    for sa in geometry.separation
                ]
            )
    return jnp.stack(columns, axis=1), virials


def accumulate(geometry: PairGeometry, magnitude):
    """Per-particle sums Σ_j m_ij e_ij (forces, or impulses) of one central pair law.

    Args:
        geometry: from `pair_geometry`.
        magnitude: (P,) magnitudes m_ij (must be 0 where not `within`).
    Returns:
        (N, 3) vectors.
    """
    return pair_sums(geometry, {"law": magnitude}, with_virial=False)[0]
