"""Geometry of the Kraynik–Reinelt lattices for planar elongation (host side, NumPy).

Planar elongation (thesis eq. 5.12) stretches z, compresses x and leaves y alone:
after a Hencky strain ε the deformation is F(ε) = diag(e^−ε, 1, e^ε).  Kraynik and
Reinelt (Int. J. Multiphase Flow 18, 1045 (1992); thesis §3.4.2) found square lattices
in the x–z plane, tilted by an angle θ against the stretching axis, that F maps onto
themselves after a strain period ε_p: F(ε_p) A0 = A0 M with an integer, unimodular M.
With A0 = L R(θ) (R a rotation), M = Rᵀ F(ε_p) R is symmetric with eigenvalues
e^{±ε_p}, so trace M = 2 cosh ε_p and tan θ = (e^{ε_p} − M11)/M12 (the stretching
eigenvector of M, in lattice coordinates).  The four cases of thesis table 3.27 are
the matrices M of `CASES` (traces 3, 6, 11 and 15); `kraynik_reinelt_case` derives
ε_p and θ from them, so they are exact rather than the six printed digits.

Which primary cell.  The lattice points at strain ε are F(ε) Λ0 whatever basis spans
them, and F(ε_p) Λ0 = Λ0; so the strain may be counted modulo ε_p, and at every
strain any basis of the lattice may serve as the primary cell.  The thesis keeps the
basis F(ε) A0 over ε ∈ [0, ε_p), whose cell is thinnest just before the reset
(L/√5 across for case 1).  Here the strain is kept in [−ε_p/2, ε_p/2) and the basis
is the Lagrange–Gauss reduced one of the lattice at that strain (the two shortest
independent lattice vectors), which changes a few times per period: a change of
basis, like the thesis's reset, only relabels which image of each particle is the
primary one.  A reduced basis makes the cell as thick as the lattice allows: for
case 1 it never gets thinner than 0.863 L (cases 2–4: 0.81, 0.72, 0.79 L, against
0.19, 0.10, 0.08 L for the thesis's cell), which sets the smallest box, the number
of neighbour cells and the longest spring.

Everything here is in units of the lattice side L (unit in-plane cell area).
"""

import functools
import math
from dataclasses import dataclass

import numpy as np

# Thesis table 3.27 (Kraynik & Reinelt 1992): the reset matrices M = [[M11, M12],
# [M12, M22]] of the first four square-lattice orientations.
CASES = {1: (2, 1, 1), 2: (5, 2, 1), 3: (10, 3, 1), 4: (10, 7, 5)}

# Strain samples per period when locating the changes of reduced basis; each change
# is then bisected to SWITCH_TOLERANCE.
SCAN_POINTS = 4096
SWITCH_TOLERANCE = 1e-14


def stretch(strain):
    """The in-plane deformation diag(e^−ε, e^ε) acting on (x, z) columns, (2, 2)."""
    return np.diag([math.exp(-strain), math.exp(strain)])


def _gauss_reduce(basis):
    """Lagrange–Gauss reduction of a 2-d basis (columns).

    Returns:
        integer (2, 2) U with basis @ U reduced: |b1| ≤ |b2| and |b1·b2| ≤ |b1|²/2.
    """
    reduced = np.array(basis, dtype=np.float64)
    unimodular = np.eye(2, dtype=np.int64)
    while True:
        if reduced[:, 0] @ reduced[:, 0] > reduced[:, 1] @ reduced[:, 1]:
            reduced, unimodular = reduced[:, ::-1], unimodular[:, ::-1]
        shift = round((reduced[:, 0] @ reduced[:, 1]) / (reduced[:, 0] @ reduced[:, 0]))
        if shift == 0:
            return unimodular
        reduced[:, 1] -= shift * reduced[:, 0]
        unimodular[:, 1] -= shift * unimodular[:, 0]


def _canonical(cell, unimodular):
    """The reduced basis in a fixed order and orientation: first the vector nearer
    the x axis with a positive x component (frame axis 0), then the other one with the
    sign that keeps the frame (axis 0, y, axis 2) right-handed (frame axis 2)."""
    vectors = cell @ unimodular
    directions = np.abs(vectors[0]) / np.linalg.norm(vectors, axis=0)
    order = [0, 1] if directions[0] >= directions[1] else [1, 0]
    unimodular = unimodular[:, order]
    vectors = vectors[:, order]
    if vectors[0, 0] < 0:
        unimodular[:, 0] *= -1
        vectors[:, 0] *= -1
    # In (x, y, z) with y in the middle, right-handedness is b0_x b2_z − b2_x b0_z > 0.
    if vectors[0, 0] * vectors[1, 1] - vectors[0, 1] * vectors[1, 0] < 0:
        unimodular[:, 1] *= -1
    return unimodular


@dataclass(frozen=True)
class KraynikReineltCase:
    """One Kraynik–Reinelt lattice and its reduced primary cells over a period.

    Attributes:
        number: the case of thesis table 3.27 (1–4).
        reset_matrix: M, ((M11, M12), (M12, M22)).
        period: ε_p = arccosh(trace M / 2), the Hencky strain after which the
            lattice repeats.
        angle: θ, between the stretching axis z and a lattice vector at zero strain.
        cell: ((x, x), (z, z)) the lattice vectors (columns) at zero strain, unit side.
        switch_strains: the strains in (−ε_p/2, ε_p/2) where the reduced basis changes.
        bases: one integer unimodular U per strain interval (len(switch_strains) + 1):
            the primary cell at strain ε in interval k is F(ε) · cell · U_k.
        thinnest: (h_0, h_2) the smallest distances between opposite faces of the
            primary cell along frame axes 0 and 2 over the whole period (unit side).
        widest: the largest in-plane diagonal of the primary cell over the period.
    """

    number: int
    reset_matrix: tuple
    period: float
    angle: float
    cell: tuple
    switch_strains: tuple
    bases: tuple
    thinnest: tuple
    widest: float

    def interval_bounds(self):
        """[(ε_start, ε_end, U)] for each strain interval of one period."""
        edges = [-self.period / 2, *self.switch_strains, self.period / 2]
        return [(edges[k], edges[k + 1], np.asarray(u)) for k, u in enumerate(self.bases)]

    def undeformed_cells(self):
        """(intervals, 2, 2): cell · U_k, the primary cell of each strain interval before
        the stretch F(ε) is applied (unit side)."""
        return np.stack([np.asarray(self.cell) @ np.asarray(u) for u in self.bases])

    def primary_cell(self, strain: float):
        """(2, 2) in-plane basis (columns: frame axes 0 and 2) at a strain in
        [−ε_p/2, ε_p/2), unit side."""
        k = int(np.searchsorted(self.switch_strains, strain, side="right"))
        return stretch(strain) @ self.undeformed_cells()[k]


def _reduced_at(cell, strain):
    return _canonical(cell, _gauss_reduce(stretch(strain) @ cell))


def _switch(cell, low, high):
    """Bisect the strain in (low, high) where the reduced basis changes."""
    start = _reduced_at(cell, low)
    while high - low > SWITCH_TOLERANCE:
        middle = 0.5 * (low + high)
        if np.array_equal(_reduced_at(cell, middle), start):
            low = middle
        else:
            high = middle
    return high


@functools.cache
def kraynik_reinelt_case(number: int) -> KraynikReineltCase:
    """The geometry of case `number` of thesis table 3.27 (see the module docstring).

    Raises:
        ValueError: for a case other than 1–4.
    """
    if number not in CASES:
        raise ValueError(f"Kraynik–Reinelt case {number!r}: valid cases are {sorted(CASES)}")
    m11, m12, m22 = CASES[number]
    period = math.acosh((m11 + m22) / 2)
    angle = math.atan((math.exp(period) - m11) / m12)
    sin, cos = math.sin(angle), math.cos(angle)
    # a1 at θ from z towards +x, a2 ⟂ a1: a rotation, so M = Rᵀ F(ε_p) R.
    cell = np.array([[sin, -cos], [cos, sin]])
    reset = np.linalg.solve(cell, stretch(period) @ cell)
    if not np.allclose(reset, [[m11, m12], [m12, m22]], atol=1e-9):
        raise AssertionError(f"case {number}: F(ε_p) does not map the lattice onto itself")

    strains = np.linspace(-period / 2, period / 2, SCAN_POINTS + 1)[:-1]
    switches, bases = [], [_reduced_at(cell, strains[0])]
    for low, high in zip(strains[:-1], strains[1:], strict=True):
        if not np.array_equal(_reduced_at(cell, high), bases[-1]):
            switches.append(_switch(cell, low, high))
            bases.append(_reduced_at(cell, high))

    thinnest = [math.inf, math.inf]
    widest = 0.0
    edges = [-period / 2, *switches, period / 2]
    for k, unimodular in enumerate(bases):
        for strain in (edges[k], edges[k + 1]):
            # |F(ε) v|² = e^−2ε v_x² + e^2ε v_z² is convex in ε: lengths of fixed
            # lattice vectors peak at the ends of an interval, heights are lowest there.
            vectors = stretch(strain) @ cell @ unimodular
            lengths = np.linalg.norm(vectors, axis=0)
            thinnest = [min(thinnest[0], 1 / lengths[1]), min(thinnest[1], 1 / lengths[0])]
            diagonals = (vectors[:, 0] + vectors[:, 1], vectors[:, 0] - vectors[:, 1])
            widest = max(widest, *(float(np.linalg.norm(d)) for d in diagonals))
    return KraynikReineltCase(
        number=number,
        reset_matrix=((m11, m12), (m12, m22)),
        period=period,
        angle=angle,
        cell=tuple(map(tuple, cell)),
        switch_strains=tuple(float(s) for s in switches),
        bases=tuple(tuple(map(tuple, u.tolist())) for u in bases),
        thinnest=tuple(thinnest),
        widest=widest,
    )
