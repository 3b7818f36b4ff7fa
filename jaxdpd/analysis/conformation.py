"""Chain conformation: size, extension, conformation tensors, hydrodynamic radius, Rouse modes.

All functions take unwrapped chain positions ``chains`` of shape
``(..., n_chains, n_beads, 3)`` (beads in chain order, equal bead masses, any leading
batch or time axes), are pure ``jax.numpy`` and may be called under ``jit``/``vmap``;
they keep the input dtype (float32 or float64).  Lengths are in units of r_c.

Conventions (with the seeds they follow):

- Radius of gyration ``R_g^2 = (1/N) sum_i |r_i - r_cm|^2`` (Ahlrichs & Dünweg,
  J. Chem. Phys. 111, 8225 (1999), eq. 21, in its equivalent pair form
  ``(1/2N^2) sum_ij r_ij^2``).  Clarke's thesis eqs. 3.5 and 5.8 print the sum without
  the ``1/N``; that is the usual definition's numerator, not a different convention.
- End-to-end vector ``R_e = r_N - r_1`` (Ahlrichs & Dünweg eq. 22).
- Hydrodynamic radius (Kirkwood), ``1/R_H = (1/N^2) sum_{i != j} <1/r_ij>``:
  Ahlrichs & Dünweg eq. 26 and Mussawisade et al., J. Chem. Phys. 123, 144905 (2005),
  eq. 14.  Note the ``1/N^2`` (not ``1/(N(N-1))``): it is the prefactor that enters
  the Kirkwood diffusion coefficient ``D = D_0/N + k_BT <1/R_H>/(6 pi eta)``.
- Rouse modes ``X_p = (1/N) sum_{n=1}^{N} r_n cos(p pi (n - 1/2)/N)``, p = 0 .. N-1
  (Ahlrichs & Dünweg eq. 37; ``X_0`` is the centre of mass).  Mussawisade et al.
  eq. 18 use the orthonormal variant ``chi_p = sqrt(2/N) sum_n r_n cos(...)``
  ``= sqrt(2N) X_p`` for p >= 1; pass ``normalization="orthonormal"`` for it.
"""

from __future__ import annotations

import jax
import jax.numpy as jnp
import numpy as np

from jaxdpd.analysis._checks import chain_positions, floating_array, positive_int

__all__ = [
    "bond_vectors",
    "center_of_mass",
    "conformation_tensor",
    "end_to_end_squared",
    "end_to_end_vector",
    "fractional_extension",
    "gaussian_chain_inverse_hydrodynamic_radius",
    "gaussian_chain_rouse_amplitudes",
    "gyration_radius_squared",
    "inverse_hydrodynamic_radius",
    "rouse_modes",
]

ROUSE_NORMALIZATIONS = ("mean", "orthonormal")


def center_of_mass(chains):
    """Centre of mass of each chain (equal bead masses).

    Args:
      chains: ``(..., n_chains, n_beads, 3)`` unwrapped positions.

    Returns:
      ``(..., n_chains, 3)``: ``r_cm = (1/N) sum_i r_i`` (thesis eq. 3.8).
    """
    return chain_positions(chains, min_beads=1).mean(axis=-2)


def gyration_radius_squared(chains):
    """Squared radius of gyration of each chain.

    Args:
      chains: ``(..., n_chains, n_beads, 3)`` unwrapped positions.

    Returns:
      ``(..., n_chains)``: ``R_g^2 = (1/N) sum_i |r_i - r_cm|^2`` (units r_c^2).
      A Gaussian chain of N beads with mean squared bond length ``l^2`` has
      ``<R_g^2> = l^2 (N^2 - 1)/(6N)`` (Doi & Edwards, *The Theory of Polymer
      Dynamics* (1986), eq. 2.52 for the discrete chain).
    """
    x = chain_positions(chains)
    relative = x - x.mean(axis=-2, keepdims=True)
    return jnp.sum(relative**2, axis=(-2, -1)) / x.shape[-2]


def end_to_end_vector(chains):
    """End-to-end vector ``R_e = r_N - r_1`` of each chain, shape ``(..., n_chains, 3)``."""
    x = chain_positions(chains)
    return x[..., -1, :] - x[..., 0, :]


def end_to_end_squared(chains):
    """``|R_e|^2`` of each chain, shape ``(..., n_chains)``; Gaussian chain: ``(N-1) l^2``."""
    return jnp.sum(end_to_end_vector(chains) ** 2, axis=-1)


def fractional_extension(chains, contour_length):
    """End-to-end distance over the fully stretched length (thesis ch. 5, "Extension").

    Args:
      chains: ``(..., n_chains, n_beads, 3)`` unwrapped positions.
      contour_length: maximum contour length, e.g. ``(N - 1) Q_0`` for FENE springs of
        maximum extension ``Q_0`` (units r_c); positive scalar (checked unless traced).

    Returns:
      ``(..., n_chains)``: ``|R_e| / contour_length``, in [0, 1) for FENE chains.
    """
    if not isinstance(contour_length, jax.core.Tracer) and (
        np.ndim(contour_length) != 0 or not float(contour_length) > 0
    ):
        raise ValueError(f"contour_length must be a positive scalar, got {contour_length!r}")
    distance = jnp.sqrt(end_to_end_squared(chains))
    return distance / jnp.asarray(contour_length, distance.dtype)


def bond_vectors(chains):
    """Bond vectors ``Q_i = r_{i+1} - r_i``, shape ``(..., n_chains, n_beads - 1, 3)``."""
    x = chain_positions(chains)
    return x[..., 1:, :] - x[..., :-1, :]


def conformation_tensor(vectors, axis: int | tuple[int, ...] = -2):
    """Second-moment (conformation) tensor ``<Q Q>`` of a set of vectors.

    Use it with end-to-end vectors (``<R_e R_e>``, the dumbbell conformation tensor of
    the whole chain) or with bond vectors (``<Q Q>`` of the springs).

    Args:
      vectors: ``(..., 3)`` array; the vector set is the axis or axes ``axis``.
      axis: axis (or axes) of ``vectors`` averaged over, not the last (Cartesian)
        one; default: the axis next to the last.

    Returns:
      ``(..., 3, 3)``: ``mean(Q_a Q_b)`` over ``axis``; its trace is ``<|Q|^2>``.
    """
    q = floating_array(vectors, "vectors", min_ndim=2)
    if q.shape[-1] != 3:
        raise ValueError(f"vectors must have a last axis of length 3, got shape {q.shape}")
    axes = (axis,) if isinstance(axis, int) else tuple(axis)
    normalized = []
    for a in axes:
        if not -q.ndim <= a < q.ndim or a % q.ndim == q.ndim - 1:
            raise ValueError(
                f"axis={axis} must name axes of vectors (shape {q.shape}) other than the "
                "last (Cartesian) one"
            )
        normalized.append(a % q.ndim)
    outer = q[..., :, None] * q[..., None, :]
    return outer.mean(axis=tuple(normalized))


def inverse_hydrodynamic_radius(chains):
    """Kirkwood inverse hydrodynamic radius of each chain.

    Args:
      chains: ``(..., n_chains, n_beads, 3)`` unwrapped positions.

    Returns:
      ``(..., n_chains)``: ``(1/N^2) sum_{i != j} 1/|r_i - r_j|`` (units 1/r_c).  The
      hydrodynamic radius is ``R_H = 1 / <this>``, the average over chains and time
      taken first (Ahlrichs & Dünweg eq. 26; Mussawisade et al. eq. 14).
    """
    x = chain_positions(chains)
    n = x.shape[-2]
    separation = x[..., :, None, :] - x[..., None, :, :]
    off_diagonal = ~np.eye(n, dtype=bool)
    distance_squared = jnp.sum(separation**2, axis=-1)
    # The diagonal is replaced by 1 before the square root so that gradients stay finite.
    safe = jnp.where(off_diagonal, distance_squared, 1.0)
    inverse = jnp.where(off_diagonal, 1.0 / jnp.sqrt(safe), 0.0)
    return jnp.sum(inverse, axis=(-2, -1)) / n**2


def gaussian_chain_inverse_hydrodynamic_radius(n_beads: int, bond_length: float = 1.0) -> float:
    """Exact ``<1/R_H>`` of a discrete Gaussian chain (reference value).

    For a Gaussian chain ``r_ij`` is Gaussian with ``<r_ij^2> = |i-j| l^2``, so
    ``<1/r_ij> = sqrt(6/pi) / (l sqrt|i-j|)`` and

        <1/R_H> = (2/N^2) sum_{k=1}^{N-1} (N - k) sqrt(6/pi) / (l sqrt(k)).

    For large N this gives Mussawisade et al. eq. 15 (from Dünweg et al., J. Chem.
    Phys. 117, 914 (2002)): ``R_H = (3l/8) sqrt(pi/6) N^(1/2) [1 - (3/4) zeta(1/2)
    N^(-1/2) + O(1/N)]``, ``zeta(1/2) = -1.4603545``.

    Args:
      n_beads: N >= 2.
      bond_length: root-mean-square bond length ``l`` (units r_c), positive.

    Returns:
      ``<1/R_H>`` as a Python float (units 1/r_c).
    """
    n = positive_int(n_beads, "n_beads", minimum=2)
    if not bond_length > 0:
        raise ValueError(f"bond_length must be positive, got {bond_length!r}")
    k = np.arange(1, n, dtype=np.float64)
    return float(2.0 / n**2 * np.sum((n - k) / np.sqrt(k)) * np.sqrt(6.0 / np.pi) / bond_length)


def _rouse_basis(n_beads: int, normalization: str, dtype):
    if normalization not in ROUSE_NORMALIZATIONS:
        raise ValueError(
            f"normalization must be one of {ROUSE_NORMALIZATIONS}, got {normalization!r}"
        )
    p = np.arange(n_beads)[:, None]
    n = np.arange(1, n_beads + 1)[None, :]
    basis = np.cos(p * np.pi * (n - 0.5) / n_beads)
    scale = 1.0 / n_beads if normalization == "mean" else np.sqrt(2.0 / n_beads)
    return jnp.asarray(scale * basis, dtype)


def rouse_modes(chains, normalization: str = "mean"):
    """Rouse-mode amplitudes of each chain, p = 0 .. N-1.

    Args:
      chains: ``(..., n_chains, n_beads, 3)`` unwrapped positions.
      normalization: ``"mean"``: ``X_p = (1/N) sum_n r_n cos(p pi (n - 1/2)/N)``
        (Ahlrichs & Dünweg eq. 37; ``X_0`` = centre of mass; the chain is recovered
        as ``r_n = X_0 + 2 sum_{p>=1} X_p cos(p pi (n - 1/2)/N)``).
        ``"orthonormal"``: ``sqrt(2/N) sum_n r_n cos(...)`` (Mussawisade et al.
        eq. 18), i.e. ``sqrt(2N) X_p``; only p >= 1 of it is meaningful.

    Returns:
      ``(..., n_chains, n_beads, 3)``: mode p along axis -2 (units r_c).
    """
    x = chain_positions(chains)
    basis = _rouse_basis(x.shape[-2], normalization, x.dtype)
    return jnp.einsum("pn,...nd->...pd", basis, x)


def gaussian_chain_rouse_amplitudes(
    n_beads: int, bond_length_squared: float = 1.0, normalization: str = "mean"
):
    """Mean squared Rouse amplitudes ``<X_p . X_p>`` of a discrete Gaussian chain.

    With bonds ``b_k = r_{k+1} - r_k`` independent, ``<b_k . b_k> = l^2``, and
    ``c_n = cos(p pi (n - 1/2)/N)``: for p >= 1, ``sum_n c_n = 0``, so
    ``X_p = (1/N) sum_k b_k S_k`` with ``S_k = sum_{n>k} c_n = -sin(p pi k/N) /
    (2 sin(p pi/2N))`` (telescoping ``2 sin(a/2) cos(a(n - 1/2)) = sin(a n) -
    sin(a(n-1))``).  Then, from ``sum_{k=1}^{N-1} sin(p pi k/N) sin(q pi k/N) =
    (N/2) delta_pq`` (1 <= p, q <= N-1),

        <X_p . X_q> = delta_pq l^2 / (8 N sin^2(p pi / 2N))          ("mean"),
        <chi_p . chi_q> = delta_pq l^2 / (4 sin^2(p pi / 2N))        ("orthonormal"):

    the modes are exactly uncorrelated.  Doi & Edwards (1986) ch. 4 give the
    continuous-chain limit ``<X_p^2> = N l^2/(2 pi^2 p^2)`` (their normalisation).

    Args:
      n_beads: N >= 2.
      bond_length_squared: ``l^2 = <|b|^2>`` (units r_c^2), positive.
      normalization: ``"mean"`` or ``"orthonormal"``, as in :func:`rouse_modes`.

    Returns:
      NumPy float64 array ``(N - 1,)``: the amplitudes for p = 1 .. N-1.
    """
    n = positive_int(n_beads, "n_beads", minimum=2)
    if not bond_length_squared > 0:
        raise ValueError(f"bond_length_squared must be positive, got {bond_length_squared!r}")
    if normalization not in ROUSE_NORMALIZATIONS:
        raise ValueError(
            f"normalization must be one of {ROUSE_NORMALIZATIONS}, got {normalization!r}"
        )
    p = np.arange(1, n)
    sin2 = np.sin(p * np.pi / (2 * n)) ** 2
    if normalization == "mean":
        return bond_length_squared / (8 * n * sin2)
    return bond_length_squared / (4 * sin2)
