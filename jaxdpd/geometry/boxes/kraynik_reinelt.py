"""Kraynik–Reinelt box for steady planar elongational flow (thesis §3.4.2–3.4.3).

Flow (thesis eq. 5.12): u = L (r − r0) with L = diag(−ε̇, 0, ε̇): z stretches,
x compresses, y is neutral; the stagnation point r0 is the box centre
(L_x/2, L_y/2, L_z/2), so the streaming velocity averages to zero over the box.

The periodic lattice deforms affinely with the flow: after a Hencky strain ε its
points are F(ε) Λ0, F = diag(e^−ε, 1, e^ε), with Λ0 the square lattice of side
L = L_x = L_z tilted by θ against z (times L_y along y).  For the angles of thesis
table 3.27 the lattice repeats after a strain ε_p, so the box state keeps the strain
modulo ε_p, in [−ε_p/2, ε_p/2): bounded, hence exact in float32 for any run length.
At every strain the primary cell is the reduced basis of the lattice (two shortest
lattice vectors; see jaxdpd.geometry.boxes.kraynik_reinelt_lattice); when the reduced basis
changes, or the strain wraps (the Kraynik–Reinelt reset), the lattice points do not
move, so no particle changes its relation to any other: particles outside the new
cell are moved back by lattice vectors on the next wrap.

Coordinates.  Positions are Cartesian, wrapped into the primary cell centred on r0;
velocities are peculiar (SLLOD, thesis eqs. 3.42–3.43).  The frame coordinates of
the cell list are the fractional coordinates in the primary cell scaled by the box
`lengths` (L, L_y, L): frame axis 0 is the lattice vector nearer x, axis 1 is y, axis
2 the other one; `frame_to_cartesian` is the current lattice matrix over those
lengths.  At zero strain the frame is the Cartesian frame rotated by θ about y.
`volume` = L² L_y is the true volume (F conserves it).

Minimum image.  A separation d is reduced by rounding its fractional coordinates in
the current (reduced) basis.  For |d| below half the thinnest height h of the cell
this is the exact minimum image: each fractional coordinate of the shortest image
is at most |d|/h < ½, and every other image is longer than h − |d| > |d|.  Pairs
within the cut-off qualify because the scene requires every height over the period
(`cell_heights`) to exceed 2 (r_c + skin), springs because they are kept below
SPRING_LIMIT · min(cell_heights) (with FENE, max_extension < min(cell_heights)/2 is
required).  Rounding fails only for longer vectors in strongly tilted cells (jax-md
issue 200), which a reduced cell also makes rarer.

Stability: keep L_y short.  Planar elongation amplifies a velocity perturbation
δu_x(y) along the neutral axis (vorticity along the stretching axis z is stretched):
the linearised Navier–Stokes equations give δu_x ∝ exp[(ε̇ − ν k_y²) t] with no
advection or pressure to stop it, and SLLOD reproduces this.  In a box periodic in y
the slowest mode has k_y = 2π/L_y, so the flow is stable only for
ε̇ < ν (2π/L_y)², ν = η/ρ (the DPD fluid of ρ = 3, a = 25, γ = 4.5 has ν ≈ 0.29, so
L_y = 10 allows ε̇ < 0.11 and L_y = 4 allows ε̇ < 0.7); above it the x-velocity of
the slowest modes, and with it the measured temperature, grows without bound.  Even
below it the modes hold ν k_y²/(ν k_y² − ε̇) times their thermal energy, which biases
P_xx; a short L_y keeps that small.  L_y needs only exceed 2 (r_c + skin) and twice
the longest spring.

Image counters count the crossings of each face of the cell in use (frame axes 0, 1,
2); since the basis changes during a period, they do not give unwrapped coordinates
(use minimum-image bond vectors for chains, as the conformation observable does).
"""

import math
from dataclasses import dataclass
from typing import ClassVar

import jax.numpy as jnp
import numpy as np

from jaxdpd import pytree
from jaxdpd.geometry.boxes.kraynik_reinelt_lattice import KraynikReineltCase, kraynik_reinelt_case
from jaxdpd.geometry.boxes.lees_edwards import SPRING_LIMIT, minimum_image_springs
from jaxdpd.geometry.boxes.periodic import fold_edge

# Relative margin taken off the static cell heights for the round-off of a float32
# strain and lattice (a relative 1e-7 at most).
HEIGHT_MARGIN = 1e-6


@pytree.dataclass
class KraynikReineltState:
    """Traced state of a Kraynik–Reinelt box.

    Attributes:
        strain: Hencky strain modulo the period, in [−ε_p/2, ε_p/2).
        elongation_rate: ε̇ (1/time, any sign); set it between chunks (e.g. to 0 to
            let stretched chains relax), or give each replica of a sweep its own.
    """

    strain: jnp.ndarray
    elongation_rate: jnp.ndarray


@dataclass(frozen=True)
class KraynikReineltBox:
    """A Kraynik–Reinelt box (see the module docstring).

    Args:
        lengths: (L, L_y, L): the side of the square x–z lattice at zero strain and
            the period along y (units of r_c); L_x must equal L_z.
        elongation_rate: ε̇ at time 0 (the state's initial value).
        case: the lattice orientation of thesis table 3.27 (1–4).
    """

    lengths: tuple[float, float, float]
    elongation_rate: float = 0.0
    case: int = 1

    name: ClassVar[str] = "kraynik_reinelt"
    flow_kind: ClassVar[str | None] = "planar_elongation"
    # Frame axes a decomposed run may cut into slabs (jaxdpd.decomposition.layout).
    slab_axes: ClassVar[tuple[int, ...]] = (1,)

    @classmethod
    def from_scene(cls, lengths, flow=None) -> "KraynikReineltBox":
        """The box of box.lengths deformed by a [flow] of kind "planar_elongation"
        (at rest without one)."""
        if flow is None:
            return cls(lengths)
        return cls(lengths, flow.elongation_rate, flow.kraynik_reinelt_case)

    def __post_init__(self):
        side, _, other = self.lengths
        if not math.isclose(side, other, rel_tol=1e-12):
            raise ValueError(
                f"box.lengths = {list(self.lengths)}: a Kraynik–Reinelt lattice is square in "
                "the x–z plane (thesis §3.4.2); give L_x = L_z"
            )
        kraynik_reinelt_case(self.case)  # validates the case number

    @property
    def geometry(self) -> KraynikReineltCase:
        """The lattice case (unit side), with its period and reduced cells."""
        return kraynik_reinelt_case(self.case)

    @property
    def period(self) -> float:
        """ε_p, the strain after which the lattice repeats."""
        return self.geometry.period

    @property
    def volume(self) -> float:
        """Box volume L² L_y (conserved by the flow)."""
        return math.prod(self.lengths)

    @property
    def centre(self) -> tuple[float, float, float]:
        """The stagnation point r0, centre of the primary cell."""
        return tuple(0.5 * length for length in self.lengths)

    @property
    def cell_heights(self) -> tuple[float, float, float]:
        """Smallest distances between opposite faces of the primary cell along each
        frame axis over the whole period (static; less a round-off margin)."""
        side, length_y, _ = self.lengths
        thinnest_0, thinnest_2 = self.geometry.thinnest
        keep = 1 - HEIGHT_MARGIN
        return (side * thinnest_0 * keep, length_y, side * thinnest_2 * keep)

    def lengths_array(self, dtype):
        """Frame edge lengths as a (3,) array of `dtype`."""
        return jnp.asarray(self.lengths, dtype)

    def initial_state(self, dtype) -> KraynikReineltState:
        """Zero strain (the tilted square lattice) and the configured rate."""
        return KraynikReineltState(
            strain=jnp.asarray(0.0, dtype), elongation_rate=jnp.asarray(self.elongation_rate, dtype)
        )

    def advance(self, box_state: KraynikReineltState, time, dt) -> KraynikReineltState:
        """Strain after a step of dt: ε += ε̇ dt, wrapped into [−ε_p/2, ε_p/2)."""
        del time  # a steady rate needs no clock
        dtype = box_state.strain.dtype
        period = jnp.asarray(self.period, dtype)
        strain = box_state.strain + box_state.elongation_rate * jnp.asarray(dt, dtype)
        strain = strain - period * jnp.floor(strain / period + 0.5)
        return box_state.set(strain=strain)

    def carry_images(self, image, before, after):
        """The image counters unchanged: they count crossings of the current frame's
        faces, and the basis changes at each lattice reset, so r + n · edges is no
        unwrapped trajectory in this box (the scene refuses "dynamics" under flow)."""
        return image

    def image_drift(self, box_state: KraynikReineltState, reference_state: KraynikReineltState):
        """A bound on how far any image that can hold a neighbour has moved against
        the primary cell since `reference_state`.

        The lattice points move affinely, p → F(Δε) p, so an image moves by at most
        (e^|Δε| − 1)|p_xz|.  A pair within the cut-off now, with both particles in the
        primary cell at the reference, is joined by an image with |p_xz| below the
        widest in-plane diagonal of the cell plus cut-off, skin and both displacements
        (all below half the thinnest height while no rebuild is due).
        """
        period = self.period
        change = box_state.strain - reference_state.strain
        change = change - period * jnp.round(change / period)
        side = self.lengths[0]
        reach = side * self.geometry.widest + 0.5 * min(self.cell_heights)
        return jnp.expm1(jnp.abs(change)) * reach

    def bind(self, box_state: KraynikReineltState) -> "BoundKraynikReinelt":
        """The box at its current strain and rate (inside a traced step)."""
        dtype = box_state.strain.dtype
        geometry = self.geometry
        side = self.lengths[0]
        cells = side * geometry.undeformed_cells()
        index = jnp.searchsorted(
            jnp.asarray(geometry.switch_strains, dtype), box_state.strain, side="right"
        )
        grow = jnp.exp(box_state.strain)
        shrink = jnp.exp(-box_state.strain)
        # F(ε) C scales the x row by e^−ε and the z row by e^ε; (F C)^−1 = C^−1 F^−1.
        lattice = jnp.asarray(cells, dtype)[index] * jnp.stack([shrink, grow])[:, None]
        inverse = jnp.asarray(np.linalg.inv(cells), dtype)[index] * jnp.stack([grow, shrink])
        return BoundKraynikReinelt(
            self.lengths,
            self.cell_heights,
            lattice,
            inverse,
            box_state.elongation_rate,
        )

    def cartesian_at_start(self, frame_positions):
        """Cartesian positions of frame positions at zero strain (host, NumPy): the
        frame there is the Cartesian one rotated by θ, so configurations drawn in it
        (uniform points, random-walk chains) keep their statistics.

        Args:
            frame_positions: (..., 3) float64 in [0, lengths).
        Returns:
            (..., 3) float64 positions in the primary cell.
        """
        rotation = self.geometry.primary_cell(0.0)
        centre = np.asarray(self.centre)
        relative = np.asarray(frame_positions, np.float64) - centre
        cartesian = relative.copy()
        cartesian[..., 0] = rotation[0, 0] * relative[..., 0] + rotation[0, 1] * relative[..., 2]
        cartesian[..., 2] = rotation[1, 0] * relative[..., 0] + rotation[1, 1] * relative[..., 2]
        return cartesian + centre


@dataclass(frozen=True)
class BoundKraynikReinelt:
    """A Kraynik–Reinelt box at one instant.

    Attributes:
        lengths: frame edges (L, L_y, L).
        cell_heights: the static heights of the box.
        lattice: (2, 2) traced, the in-plane primary cell: rows (x, z), columns the
            lattice vectors of frame axes 0 and 2.
        inverse: (2, 2) its inverse (Cartesian (x, z) → fractional coordinates).
        current_elongation_rate: ε̇ now.
    """

    lengths: tuple[float, float, float]
    cell_heights: tuple[float, float, float]
    lattice: jnp.ndarray
    inverse: jnp.ndarray
    current_elongation_rate: jnp.ndarray

    @property
    def lattice_vectors(self):
        """(3, 3) the lattice vectors of frame axes 0, 1, 2 as columns."""
        zero = jnp.zeros((), self.lattice.dtype)
        length_y = jnp.asarray(self.lengths[1], self.lattice.dtype)
        a, b = self.lattice[0], self.lattice[1]
        return jnp.stack(
            [
                jnp.stack([a[0], zero, a[1]]),
                jnp.stack([zero, length_y, zero]),
                jnp.stack([b[0], zero, b[1]]),
            ]
        )

    # -- flow ------------------------------------------------------------------------
    @property
    def velocity_gradient(self):
        """(3, 3) L = diag(−ε̇, 0, ε̇) (thesis eq. 5.12)."""
        rate = self.current_elongation_rate
        return jnp.diag(jnp.stack([-rate, jnp.zeros_like(rate), rate]))

    def streaming_velocity(self, positions):
        """u(r) = ε̇ (−(x − x0), 0, z − z0) for positions (N, 3)."""
        x0, _, z0 = self.lengths[0] / 2, self.lengths[1] / 2, self.lengths[2] / 2
        rate = self.current_elongation_rate
        zero = jnp.zeros_like(positions[:, 1])
        return jnp.stack(
            [-rate * (positions[:, 0] - x0), zero, rate * (positions[:, 2] - z0)], axis=1
        )

    def streaming_along_pair(self, separation, inverse_distance):
        """(L r_ij) · e_ij = ε̇ (dz² − dx²)/r: the flow's part of the relative velocity."""
        dx, _, dz = separation
        return self.current_elongation_rate * (dz * dz - dx * dx) * inverse_distance

    # -- geometry ----------------------------------------------------------------------
    def _fractional(self, dx, dz):
        """In-plane fractional coordinates (s_0, s_2) of Cartesian (dx, dz)."""
        g = self.inverse
        return g[0, 0] * dx + g[0, 1] * dz, g[1, 0] * dx + g[1, 1] * dz

    def _shift(self, dx, dz, n0, n2):
        """(dx, dz) − lattice · (n0, n2)."""
        a = self.lattice
        return dx - (a[0, 0] * n0 + a[0, 1] * n2), dz - (a[1, 0] * n0 + a[1, 1] * n2)

    def separation(self, components):
        """Minimum image (see the module docstring) of raw separations (dx, dy, dz)."""
        dx, dy, dz = components
        length_y = self.lengths[1]
        s0, s2 = self._fractional(dx, dz)
        dx, dz = self._shift(dx, dz, jnp.round(s0), jnp.round(s2))
        return dx, dy - length_y * jnp.round(dy / length_y), dz

    def minimum_image_vectors(self, separations):
        """`separation` for vectors of shape (..., 3)."""
        components = self.separation(tuple(separations[..., axis] for axis in range(3)))
        return jnp.stack(components, axis=-1)

    spring_vectors = minimum_image_springs

    def springs_past_half_box(self, separation, springs, image_difference):
        """Whether some spring's x–z part is longer than SPRING_LIMIT of the thinnest
        in-plane cell height, or its y part longer than SPRING_LIMIT L_y.  Below one
        half a spring is its own minimum image in every cell of the period (the
        lattice is the product of the x–z lattice and the period L_y along y), so it is
        followed by continuity; image counters cannot tell, the basis changes."""
        del separation, image_difference
        height_0, length_y, height_2 = self.cell_heights
        in_plane = SPRING_LIMIT * min(height_0, height_2)
        too_long = springs[..., 0] ** 2 + springs[..., 2] ** 2 > in_plane * in_plane
        return jnp.any(too_long | (jnp.abs(springs[..., 1]) > SPRING_LIMIT * length_y))

    def wrap(self, positions, image):
        """Move positions that left the primary cell back by lattice vectors, and count
        the faces crossed (frame axes 0, 1, 2).  Particles inside are not touched."""
        x0, _, z0 = (0.5 * length for length in self.lengths)
        s0, s2 = self._fractional(positions[:, 0] - x0, positions[:, 2] - z0)
        crossings_0 = jnp.floor(s0 + 0.5)
        crossings_2 = jnp.floor(s2 + 0.5)
        x, z = self._shift(positions[:, 0], positions[:, 2], crossings_0, crossings_2)
        length_y = jnp.asarray(self.lengths[1], positions.dtype)
        crossings_y = jnp.floor(positions[:, 1] / length_y)
        y, crossings_y = fold_edge(positions[:, 1] - crossings_y * length_y, crossings_y, length_y)
        crossings = jnp.stack([crossings_0, crossings_y, crossings_2], axis=1)
        return jnp.stack([x, y, z], axis=1), image + crossings.astype(image.dtype)

    def frame_positions(self, positions):
        """Fractional coordinates in the primary cell times the frame lengths, wrapped
        into [0, lengths) (y is kept as it is)."""
        side = self.lengths[0]
        x0, _, z0 = (0.5 * length for length in self.lengths)
        s0, s2 = self._fractional(positions[:, 0] - x0, positions[:, 2] - z0)

        def wrapped(fraction):
            frame = side * (fraction + 0.5 - jnp.floor(fraction + 0.5))
            return jnp.where(frame >= side, frame - side, frame)

        return jnp.stack([wrapped(s0), positions[:, 1], wrapped(s2)], axis=1)

    def frame_to_cartesian(self, components):
        """Frame separation (d0, dy, d2) → Cartesian: lattice · (d0, d2)/L, and dy."""
        d0, dy, d2 = components
        a = self.lattice / self.lengths[0]
        return a[0, 0] * d0 + a[0, 1] * d2, dy, a[1, 0] * d0 + a[1, 1] * d2
