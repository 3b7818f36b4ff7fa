"""Single-chain static and intermediate (dynamic) structure factors.

    S(q)    = (1/N) | sum_i exp(i q . r_i) |^2,
    S(q, t) = (1/N) Re[ sum_i exp(i q . r_i(t0 + t)) sum_j exp(-i q . r_j(t0)) ],

per chain of N beads (Ahlrichs & Dünweg, J. Chem. Phys. 111, 8225 (1999), eqs. 24 and
40; Mussawisade et al., J. Chem. Phys. 123, 144905 (2005), eq. 20); ``S(q, 0) = S(q)``.
The average over chains, time origins and the directions of ``q`` is the caller's
(:func:`shell_average` for the directions).  ``S -> N`` as ``q -> 0`` and ``S -> 1``
for ``q`` much larger than the inverse bond length.

Wave vectors are those of the periodic box, ``q = 2 pi (n_x/L_x, n_y/L_y, n_z/L_z)``
with integer ``n``; only one of each pair ``+-q`` is kept (``S(-q) = S(q)`` for real
positions).  Positions must be unwrapped along each chain.
"""

from __future__ import annotations

import jax.numpy as jnp
import numpy as np

from jaxdpd.analysis._checks import chain_positions, floating_array, positive_int

__all__ = [
    "WaveVectorShells",
    "chain_intermediate_scattering",
    "chain_structure_factor",
    "shell_average",
    "wave_vector_shells",
]


class WaveVectorShells:
    """Box-compatible wave vectors grouped into shells of equal width in ``|q|``.

    Attributes:
      vectors: NumPy ``(M, 3)`` float64 wave vectors (units 1/r_c), one of each ``+-q``.
      shell: NumPy ``(M,)`` int64 shell index of each vector.
      q: NumPy ``(n_shells,)`` mean ``|q|`` of the vectors in each shell.
      vectors_per_shell: NumPy ``(n_shells,)`` int64.
    """

    def __init__(self, vectors, shell, n_shells):
        self.vectors = vectors
        self.shell = shell
        self.vectors_per_shell = np.bincount(shell, minlength=n_shells)
        norms = np.linalg.norm(vectors, axis=1)
        self.q = np.bincount(shell, weights=norms, minlength=n_shells) / self.vectors_per_shell


def wave_vector_shells(
    box_lengths, q_max: float, shell_width: float | None = None, max_per_shell: int | None = None
) -> WaveVectorShells:
    """Wave vectors ``2 pi n / L`` with ``0 < |q| <= q_max``, grouped in shells of ``|q|``.

    Args:
      box_lengths: ``(3,)`` box edge lengths (units r_c), positive.
      q_max: largest ``|q|`` (units 1/r_c), at least the smallest ``2 pi / L``.
      shell_width: width of the ``|q|`` shells; default ``2 pi / max(L)``, the
        spacing of the coarsest direction of the lattice.  Empty shells are dropped.
      max_per_shell: keep at most this many vectors per shell (the first ones in a
        fixed, direction-spread order), to bound the cost; default: all.

    Returns:
      :class:`WaveVectorShells`.  Computed with NumPy, outside ``jit``: the vectors
      are constants of the analysis.
    """
    lengths = np.asarray(box_lengths, dtype=np.float64)
    if lengths.shape != (3,) or not np.all(lengths > 0):
        raise ValueError(f"box_lengths must be 3 positive lengths, got {box_lengths!r}")
    q_min = 2 * np.pi / lengths.max()
    if not np.isfinite(q_max) or q_max < 2 * np.pi / lengths.max():
        raise ValueError(f"q_max must be at least 2 pi / max(L) = {q_min:.4g}, got {q_max!r}")
    width = q_min if shell_width is None else float(shell_width)
    if not width > 0:
        raise ValueError(f"shell_width must be positive, got {shell_width!r}")
    n_max = np.floor(q_max * lengths / (2 * np.pi)).astype(int)
    grids = np.meshgrid(*(np.arange(-k, k + 1) for k in n_max), indexing="ij")
    n = np.stack([g.ravel() for g in grids], axis=1)
    # One of each +-n: the first nonzero component positive.
    first_nonzero = np.where(n[:, 0] != 0, n[:, 0], np.where(n[:, 1] != 0, n[:, 1], n[:, 2]))
    n = n[first_nonzero > 0]
    vectors = 2 * np.pi * n / lengths
    norms = np.linalg.norm(vectors, axis=1)
    keep = norms <= q_max * (1 + 1e-12)
    vectors, norms = vectors[keep], norms[keep]
    order = np.lexsort((np.arange(len(norms)), norms))
    vectors, norms = vectors[order], norms[order]
    raw_shell = np.floor((norms - q_min * (1 - 1e-9)) / width + 1e-9).astype(np.int64)
    occupied, shell = np.unique(raw_shell, return_inverse=True)
    if max_per_shell is not None:
        limit = positive_int(max_per_shell, "max_per_shell")
        keep = np.zeros(len(shell), bool)
        for s in range(len(occupied)):
            members = np.flatnonzero(shell == s)
            # Spread over directions: every k-th member rather than the first ones.
            keep[members[:: max(1, len(members) // limit)][:limit]] = True
        vectors, shell = vectors[keep], shell[keep]
    return WaveVectorShells(vectors, shell.astype(np.int64), len(occupied))


def _phase_sums(chains, wave_vectors):
    """``sum_i cos(q.r_i)`` and ``sum_i sin(q.r_i)``, each ``(..., n_chains, M)``."""
    q = jnp.asarray(wave_vectors, chains.dtype)
    phase = jnp.einsum("...nd,md->...nm", chains, q)
    return jnp.cos(phase).sum(axis=-2), jnp.sin(phase).sum(axis=-2)


def _wave_vectors(wave_vectors):
    q = floating_array(wave_vectors, "wave_vectors", min_ndim=2)
    if q.ndim != 2 or q.shape[1] != 3:
        raise ValueError(f"wave_vectors must have shape (M, 3), got {q.shape}")
    return q


def chain_structure_factor(chains, wave_vectors):
    """Single-chain static structure factor for each chain and wave vector.

    Args:
      chains: ``(..., n_chains, n_beads, 3)`` unwrapped positions.
      wave_vectors: ``(M, 3)`` (units 1/r_c), e.g. ``wave_vector_shells(...).vectors``.

    Returns:
      ``(..., n_chains, M)``: ``(1/N) |sum_i exp(i q . r_i)|^2`` (dimensionless).
    """
    x = chain_positions(chains, min_beads=1)
    cos_sum, sin_sum = _phase_sums(x, _wave_vectors(wave_vectors))
    return (cos_sum**2 + sin_sum**2) / x.shape[-2]


def chain_intermediate_scattering(chains_origin, chains_later, wave_vectors):
    """Single-chain intermediate scattering function from two configurations.

    Args:
      chains_origin: ``(..., n_chains, n_beads, 3)`` unwrapped positions at ``t0``.
      chains_later: same shape, the same chains at ``t0 + t``.
      wave_vectors: ``(M, 3)`` (units 1/r_c).

    Returns:
      ``(..., n_chains, M)``: ``(1/N) Re[rho_q(t0 + t) rho_q(t0)^*]`` with
      ``rho_q = sum_i exp(i q . r_i)``; averaged over origins and chains this is
      ``S(q, t)`` (Ahlrichs & Dünweg eq. 40).
    """
    x0 = chain_positions(chains_origin, "chains_origin", min_beads=1)
    x1 = chain_positions(chains_later, "chains_later", min_beads=1)
    if x0.shape != x1.shape:
        raise ValueError(
            f"chains_origin and chains_later must have the same shape, got {x0.shape} "
            f"and {x1.shape}"
        )
    q = _wave_vectors(wave_vectors)
    cos0, sin0 = _phase_sums(x0, q)
    cos1, sin1 = _phase_sums(x1, q)
    return (cos1 * cos0 + sin1 * sin0) / x0.shape[-2]


def shell_average(values, shells: WaveVectorShells):
    """Average over the wave vectors of each shell (last axis of ``values``).

    Args:
      values: ``(..., M)`` per-wave-vector values, e.g. from
        :func:`chain_structure_factor`.
      shells: the :class:`WaveVectorShells` the wave vectors came from.

    Returns:
      ``(..., n_shells)``: mean over the vectors of each shell; pair it with
      ``shells.q``.
    """
    v = floating_array(values, "values")
    if v.shape[-1] != len(shells.shell):
        raise ValueError(
            f"values must have {len(shells.shell)} wave vectors on the last axis, "
            f"got shape {v.shape}"
        )
    n_shells = len(shells.vectors_per_shell)
    membership = jnp.asarray(np.eye(n_shells)[shells.shell] / shells.vectors_per_shell, v.dtype)
    return v @ membership
