"""The D3Q19 lattice and its orthogonal mode basis.

Velocities c_i (in units of grid spacing per LB time step) are the rest vector, the
6 nearest and the 12 next-nearest neighbours of a simple cubic lattice, with weights
w_0 = 1/3, w_{1..6} = 1/18, w_{7..18} = 1/36 and sound speed c_s² = 1/3 (lattice
units).  Mode k of the populations f_i is

    m_k = Σ_i e_ki f_i,         Σ_i w_i e_ki e_li = b_k δ_kl,

with the basis of Dünweg, Schiller and Ladd (Phys. Rev. E 76, 036704 (2007), table I;
the D3Q19 version of d'Humières et al., Phil. Trans. R. Soc. A 360, 437 (2002)):

    k = 0          1                                  mass density ρ
    k = 1, 2, 3    c_x, c_y, c_z                       momentum density j
    k = 4          c² − 1                              bulk stress
    k = 5 … 9      3c_x² − c², c_y² − c_z², c_x c_y,   shear stress
                   c_y c_z, c_x c_z
    k = 10 … 18    (3c² − 5) c_α, (c_β² − c_γ²) c_α,   kinetic ("ghost") modes
                   3c⁴ − 6c² + 1, (2c² − 3)(3c_x² − c²),
                   (2c² − 3)(c_y² − c_z²)

Orthogonality with the weights makes the inverse transform f_i = w_i Σ_k e_ki m_k/b_k.
Everything here is NumPy, built once at import, exact in float64.
"""

import numpy as np

N_VELOCITIES = 19
SOUND_SPEED_SQ = 1.0 / 3.0

_AXES = np.eye(3, dtype=np.int64)
_EDGES = [
    sign_a * _AXES[a] + sign_b * _AXES[b]
    for a, b in ((0, 1), (1, 2), (0, 2))
    for sign_a, sign_b in ((1, 1), (-1, -1), (1, -1), (-1, 1))
]

VELOCITIES = np.array(
    [[0, 0, 0]] + [sign * axis for axis in _AXES for sign in (1, -1)] + _EDGES, np.int64
)
"""(19, 3) integer lattice velocities c_i."""

WEIGHTS = np.array([1 / 3] + [1 / 18] * 6 + [1 / 36] * 12)
"""(19,) lattice weights w_i (Σ w_i = 1, Σ w_i c_iα c_iβ = c_s² δ_αβ)."""


def _mode_basis() -> np.ndarray:
    cx, cy, cz = (VELOCITIES[:, a].astype(np.float64) for a in range(3))
    c_sq = cx * cx + cy * cy + cz * cz
    rows = [
        np.ones(N_VELOCITIES),
        cx,
        cy,
        cz,
        c_sq - 1,
        3 * cx * cx - c_sq,
        cy * cy - cz * cz,
        cx * cy,
        cy * cz,
        cx * cz,
        (3 * c_sq - 5) * cx,
        (3 * c_sq - 5) * cy,
        (3 * c_sq - 5) * cz,
        (cy * cy - cz * cz) * cx,
        (cz * cz - cx * cx) * cy,
        (cx * cx - cy * cy) * cz,
        3 * c_sq * c_sq - 6 * c_sq + 1,
        (2 * c_sq - 3) * (3 * cx * cx - c_sq),
        (2 * c_sq - 3) * (cy * cy - cz * cz),
    ]
    return np.stack(rows)


MODE_BASIS = _mode_basis()
"""(19, 19) rows e_k: m = MODE_BASIS @ f."""

MODE_NORMS = (MODE_BASIS * MODE_BASIS) @ WEIGHTS
"""(19,) b_k = Σ_i w_i e_ki²."""

INVERSE_MODE_BASIS = WEIGHTS[:, None] * MODE_BASIS.T / MODE_NORMS[None, :]
"""(19, 19): f = INVERSE_MODE_BASIS @ m."""

MASS_MODE = 0
MOMENTUM_MODES = (1, 2, 3)
BULK_MODE = 4
SHEAR_MODES = (5, 6, 7, 8, 9)
GHOST_MODES = tuple(range(10, 19))
HYDRODYNAMIC_MODES = (MASS_MODE, *MOMENTUM_MODES, BULK_MODE, *SHEAR_MODES)
"""Modes 0–9: all that the collision reads (the ghosts relax fully, to m^eq = 0)."""
FLUCTUATING_MODES = (BULK_MODE, *SHEAR_MODES, *GHOST_MODES)
"""Modes that are not conserved by the collision: they relax and get thermal noise."""

OPPOSITE = np.array(
    [int(np.flatnonzero((VELOCITIES == -c).all(axis=1))[0]) for c in VELOCITIES], np.int64
)
"""(19,) index of −c_i."""
