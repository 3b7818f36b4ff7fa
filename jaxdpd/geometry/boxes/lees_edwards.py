"""Lees–Edwards box for simple shear flow (thesis §3.3, Lees & Edwards 1972).

Flow: u_x = γ̇ (y − L_y/2), u_y = u_z = 0, i.e. the velocity gradient L with the one
entry L_xy = γ̇; the box centre is the stagnation plane, so the streaming velocity
averages to zero over the box.

The periodic image above the primary box (y + L_y) is displaced in x by the offset
Δ(t) and moves with velocity γ̇ L_y relative to it: the lattice vectors are
a1 = (L_x, 0, 0), a2 = (Δ, L_y, 0), a3 = (0, 0, L_z).  The offset grows as
dΔ/dt = γ̇ L_y and is kept in [−L_x/2, L_x/2) (adding L_x changes no image), so it
stays exact in float32 for any strain.

Unwrapped coordinates are r + n_x a1 + n_y a2 + n_z a3 = r + n · edges, with n the
image counters and a2 = (Δ, L_y, 0) at the same instant (`BoundLeesEdwards.unwrap`;
the H5MD file stores exactly these edges with each frame, so the rule reads the same
there: `jaxdpd.io.reader.read_unwrapped_positions`).  They follow each particle
continuously through the laboratory frame: between crossings n_y Δ grows as
n_y γ̇ L_y t, the streaming velocity of the image the particle sits in.  When the
offset wraps by −L_x, n_y a2 jumps by −n_y L_x x̂, so every particle's x counter gains
n_y (`LeesEdwardsBox.carry_images`); without that, particles that have crossed the
y boundary jumped by multiples of L_x at each wrap.  This needs |γ̇| L_y Δt < L_x/2
(the wraps of a step are read from the change of Δ; build() refuses faster shear,
jaxdpd.run.resources), far beyond any usable step.

Velocities are stored as peculiar velocities c = v − u(r) (SLLOD, thesis eqs.
3.42–3.43).  A particle leaving through y = L_y re-enters at y − L_y with x − Δ; its
laboratory velocity jumps by −γ̇ L_y, its peculiar velocity does not change.  A pair
across the moving boundary has the minimum-image separation of thesis eq. 3.19 (y
first, then x shifted by the offset) and the laboratory relative velocity
v_i − v_j = c_i − c_j + L (r_i − r_j) (thesis eq. 3.18).

The cell list bins the sheared-frame coordinates (u, y, z), u = x − (Δ/L_y) y
(mod L_x), in which the lattice is rectangular; cells along u are made thick enough
for the most tilted frame, |Δ|/L_y ≤ L_x/(2 L_y).
"""

import math
from dataclasses import dataclass
from typing import ClassVar

import jax.numpy as jnp

from jaxdpd import pytree
from jaxdpd.geometry.boxes.periodic import fold_edge

# A spring component above this fraction of the box edge stops the run (see
# BoundLeesEdwards.springs_past_half_box).
SPRING_LIMIT = 0.45


# The box clock's precision (see LeesEdwardsState.time).
CLOCK_DTYPE = jnp.float64


def minimum_image_springs(box, separation, image_difference):
    """Minimum-image spring vectors (thesis eq. 3.4) and whether any is ambiguous
    (`box.springs_past_half_box`): the `spring_vectors` of the flowing boxes.  In a
    Lees–Edwards box the image counters, carried across offset wraps
    (`carry_images`), would unwrap springs too; the minimum image is kept so that
    sheared chain trajectories stay as they were.  Kraynik–Reinelt counters give no
    unwrapped coordinates.

    Args:
        box: a LeesEdwardsBox or KraynikReineltBox.
        separation: (..., 3) raw r_{k+1} − r_k of wrapped positions.
        image_difference: (..., 3) int image counters n_{k+1} − n_k (unused).
    Returns:
        (springs (..., 3), bool scalar).
    """
    springs = box.minimum_image_vectors(separation)
    return springs, box.springs_past_half_box(separation, springs, image_difference)


@pytree.dataclass
class LeesEdwardsState:
    """Traced state of a Lees–Edwards box.

    Attributes:
        offset: image offset Δ in x of the box above, in [−L_x/2, L_x/2).
        shear_rate: the set shear rate γ̇ (the amplitude γ̇0 of an oscillatory shear);
            change it between chunks for start-up or cessation, or give each replica
            of a vmapped sweep its own.
        time: the box's clock, which sets the phase of an oscillatory shear; float64
            whatever the scene's precision and kept within one period 2π/ω, so the
            phase stays exact over any number of periods (a float32 clock drifted by
            0.06 rad over 2·10⁶ steps of 0.04).
    """

    offset: jnp.ndarray
    shear_rate: jnp.ndarray
    time: jnp.ndarray


@dataclass(frozen=True)
class LeesEdwardsBox:
    """A Lees–Edwards box with edges `lengths` (units of r_c).

    Args:
        lengths: (L_x, L_y, L_z).
        shear_rate: γ̇ at time 0 (the state's initial value; 1/time units).
        oscillation_frequency: ω of an oscillatory shear γ̇(t) = γ̇0 cos(ω t); None for
            a steady shear rate.
    """

    lengths: tuple[float, float, float]
    shear_rate: float = 0.0
    oscillation_frequency: float | None = None

    name: ClassVar[str] = "lees_edwards"
    flow_kind: ClassVar[str | None] = "shear"
    # Frame axes a decomposed run may cut into slabs (jaxdpd.decomposition.layout).
    slab_axes: ClassVar[tuple[int, ...]] = (1, 2)

    @classmethod
    def from_scene(cls, lengths, flow=None) -> "LeesEdwardsBox":
        """The box of box.lengths sheared by a [flow] of kind "shear" (at rest
        without one)."""
        if flow is None:
            return cls(lengths)
        return cls(lengths, flow.shear_rate, flow.oscillation_frequency)

    @property
    def volume(self) -> float:
        """Box volume L_x L_y L_z."""
        return math.prod(self.lengths)

    @property
    def cell_heights(self) -> tuple[float, float, float]:
        """Smallest frame-row thicknesses over all offsets: along u the cell planes are
        tilted by Δ/L_y, at worst L_x/(2 L_y)."""
        lx, ly, lz = self.lengths
        return (lx / math.hypot(1.0, lx / (2 * ly)), ly, lz)

    def lengths_array(self, dtype):
        """Edge lengths as a (3,) array of `dtype`."""
        return jnp.asarray(self.lengths, dtype)

    def initial_state(self, dtype) -> LeesEdwardsState:
        """Zero offset and the configured shear rate at time 0."""
        return LeesEdwardsState(
            offset=jnp.asarray(0.0, dtype),
            shear_rate=jnp.asarray(self.shear_rate, dtype),
            time=jnp.asarray(0.0, CLOCK_DTYPE),
        )

    def shear_rate_at(self, box_state: LeesEdwardsState, time):
        """γ̇(t): the set rate, times cos(ω t) for an oscillatory shear."""
        if self.oscillation_frequency is None:
            return box_state.shear_rate
        phase = jnp.cos(self.oscillation_frequency * time)
        return box_state.shear_rate * phase.astype(box_state.shear_rate.dtype)

    def advance(self, box_state: LeesEdwardsState, time, dt) -> LeesEdwardsState:
        """Offset after a step of dt: Δ += γ̇(t + dt/2) L_y dt, wrapped into
        [−L_x/2, L_x/2) (midpoint rule: exact for steady shear)."""
        del time  # the box keeps its own clock
        lx, ly, _ = self.lengths
        dtype = box_state.offset.dtype
        clock_step = jnp.asarray(dt, CLOCK_DTYPE)
        rate = self.shear_rate_at(box_state, box_state.time + 0.5 * clock_step)
        dt = jnp.asarray(dt, dtype)
        offset = box_state.offset + rate * ly * dt
        offset = offset - lx * jnp.floor(offset / lx + 0.5)
        clock = box_state.time + clock_step
        if self.oscillation_frequency is not None:
            # Only the phase matters: a clock kept within one period never loses the
            # resolution of its step.
            period = 2 * math.pi / self.oscillation_frequency
            clock = clock - period * jnp.floor(clock / period)
        return box_state.set(offset=offset, time=clock)

    def carry_images(self, image, before: LeesEdwardsState, after: LeesEdwardsState):
        """Image counters that keep r + n · edges unchanged across a step's offset wrap.

        Δ_after = Δ_before + γ̇ L_y Δt − k L_x with k wraps; adding n_y k to n_x leaves
        n_x L_x + n_y Δ continuous.  Call with the counters before the step's `wrap`
        (a particle crossing y in this step is shifted by the new offset there).

        Args:
            image: (N, 3) int32 image counters.
            before, after: the box state at the start and end of the step.
        Returns:
            (N, 3) int32 counters.
        """
        lx = self.lengths[0]
        wraps = jnp.round((before.offset - after.offset) / lx).astype(image.dtype)
        return image.at[:, 0].add(wraps * image[:, 1])

    def image_drift(self, box_state: LeesEdwardsState, reference_state: LeesEdwardsState):
        """|ΔΔ|: how far the images across y moved in x since `reference_state`
        (modulo L_x, the smaller way round)."""
        lx = self.lengths[0]
        change = box_state.offset - reference_state.offset
        return jnp.abs(change - lx * jnp.round(change / lx))

    def bind(self, box_state: LeesEdwardsState) -> "BoundLeesEdwards":
        """The box at its current offset and shear rate (inside a traced step)."""
        return BoundLeesEdwards(
            self.lengths,
            box_state.offset,
            self.shear_rate_at(box_state, box_state.time),
            self.cell_heights,
        )


@dataclass(frozen=True)
class BoundLeesEdwards:
    """A Lees–Edwards box at one instant (holds traced offset and shear rate)."""

    lengths: tuple[float, float, float]
    offset: jnp.ndarray
    current_shear_rate: jnp.ndarray
    cell_heights: tuple[float, float, float]

    @property
    def volume(self) -> float:
        return math.prod(self.lengths)

    def lengths_array(self, dtype):
        return jnp.asarray(self.lengths, dtype)

    @property
    def tilt(self):
        """Δ/L_y: the x shift per unit y of the sheared lattice."""
        return self.offset / self.lengths[1]

    @property
    def velocity_gradient(self):
        """(3, 3) L with L_xy = γ̇: u = L (r − centre)."""
        return jnp.zeros((3, 3), self.offset.dtype).at[0, 1].set(self.current_shear_rate)

    def streaming_velocity(self, positions):
        """u(r) = γ̇ (y − L_y/2) x̂ for wrapped positions (N, 3)."""
        u_x = self.current_shear_rate * (positions[:, 1] - 0.5 * self.lengths[1])
        return jnp.zeros_like(positions).at[:, 0].set(u_x)

    def streaming_along_pair(self, separation, inverse_distance):
        """(L r_ij) · e_ij = γ̇ dy dx / r: the flow's part of the relative velocity."""
        dx, dy, _ = separation
        return self.current_shear_rate * dy * dx * inverse_distance

    def separation(self, components):
        """Minimum image across the moving boundary (thesis eq. 3.19): y first, the
        offset applied to x for pairs across y, then x and z."""
        dx, dy, dz = components
        lx, ly, lz = self.lengths
        crossings = jnp.round(dy / ly)
        dy = dy - ly * crossings
        dx = dx - crossings * self.offset
        dx = dx - lx * jnp.round(dx / lx)
        dz = dz - lz * jnp.round(dz / lz)
        return dx, dy, dz

    def minimum_image_vectors(self, separations):
        """`separation` for vectors of shape (..., 3)."""
        components = self.separation(tuple(separations[..., axis] for axis in range(3)))
        return jnp.stack(components, axis=-1)

    spring_vectors = minimum_image_springs

    def springs_past_half_box(self, separation, springs, image_difference):
        """Whether some spring has a component beyond SPRING_LIMIT of the box edge.

        Springs are read by minimum image in this box, so it relies on continuity: a
        spring grows by far less than 5 % of an edge per step, so it is caught here
        before its minimum image becomes ambiguous at one half.
        """
        del separation, image_difference
        limit = SPRING_LIMIT * self.lengths_array(springs.dtype)
        return jnp.any(jnp.abs(springs) > limit)

    def wrap(self, positions, image):
        """Wrap into the primary box: y first (x shifted by ∓Δ for each crossing),
        then x and z.  Image counters count the crossings of each face."""
        lx, ly, lz = (jnp.asarray(length, positions.dtype) for length in self.lengths)

        def wrap_axis(coordinate, length):
            crossings = jnp.floor(coordinate / length)
            return fold_edge(coordinate - crossings * length, crossings, length)

        y, crossings_y = wrap_axis(positions[:, 1], ly)
        x, crossings_x = wrap_axis(positions[:, 0] - crossings_y * self.offset, lx)
        z, crossings_z = wrap_axis(positions[:, 2], lz)
        crossings = jnp.stack([crossings_x, crossings_y, crossings_z], axis=1)
        return jnp.stack([x, y, z], axis=1), image + crossings.astype(image.dtype)

    def unwrap(self, positions, image):
        """Unwrapped positions r + n_x a1 + n_y a2 + n_z a3 (a2 = (Δ, L_y, 0)), continuous
        in time when the counters are carried across offset wraps (see the module
        docstring)."""
        image = image.astype(positions.dtype)
        lengths = self.lengths_array(positions.dtype)
        return (positions + image * lengths).at[:, 0].add(image[:, 1] * self.offset)

    def frame_positions(self, positions):
        """Sheared-frame coordinates (u, y, z), u = x − (Δ/L_y) y wrapped into [0, L_x)."""
        lx = self.lengths[0]
        u = positions[:, 0] - self.tilt * positions[:, 1]
        u = u - lx * jnp.floor(u / lx)
        u = jnp.where(u >= lx, u - lx, u)
        return positions.at[:, 0].set(u)

    def frame_to_cartesian(self, components):
        """(du, dy, dz) → (du + (Δ/L_y) dy, dy, dz)."""
        du, dy, dz = components
        return du + self.tilt * dy, dy, dz
