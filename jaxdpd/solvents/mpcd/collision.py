"""MPCD collision rules: stochastic rotation dynamics (SRD) in cells, the
single-particle rotation of the solvent-free Rouse variant, and the Maxwell–Boltzmann
scaling thermostat.

SRD (Malevanets & Kapral, J. Chem. Phys. 110, 8605 (1999); Mussawisade et al.,
J. Chem. Phys. 123, 144905 (2005), eq. 2): in every cell c the velocities relative
to the cell's centre-of-mass velocity are rotated by a fixed angle α about an axis
n_c drawn uniformly on the unit sphere for each cell and collision,

    u_c = Σ_{i∈c} m_i v_i / Σ_{i∈c} m_i,     v_i ← u_c + R(n_c, α) (v_i − u_c).

Mass, momentum and kinetic energy of every cell are conserved; an empty cell is never
looked at and a lone particle has v_i − u_c = 0, so it keeps its velocity.

Randomness is counter-based (jaxdpd.engine.noise): the axis of a cell is a function of
(seed, collision index, cell id) only, so results do not depend on particle order.
"""

import math

import jax.numpy as jnp

from jaxdpd.dyadic import dyadic_sum
from jaxdpd.engine import noise
from jaxdpd.solvents.mpcd.cells import bin_particles, cell_totals, grid_shift
from jaxdpd.trigonometry import sincos_turns

# Bit streams of the collision key: rotation axes (per cell, or per particle in the
# Rouse variant) and the thermostat's Gaussian draws (per particle).  The grid shift
# uses jaxdpd.solvents.mpcd.cells.SHIFT_STREAMS.
AXIS_STREAMS = (0, 1)
THERMOSTAT_GAUSSIAN_STREAMS = (2, 3, 4)  # pair_gaussian streams (bit streams 4–9)


def random_axes(key, sites, dtype):
    """Unit vectors uniform on the sphere, one per site.

    cos θ = 2 u₁ − 1 and φ = 2π u₂ with u₁, u₂ uniform on (0, 1) (Archimedes: the
    height of a uniform point on the sphere is uniform).

    Args:
        key: uint32 collision key.
        sites: (K,) int site identities (cell ids or particle ids).
        dtype: floating dtype.
    Returns:
        (K, 3) unit vectors.
    """
    u1, u2 = (
        noise.bits_to_unit_interval(noise.site_bits(key, sites, stream), dtype)
        for stream in AXIS_STREAMS
    )
    cos_theta = 2 * u1 - 1
    sin_theta = jnp.sqrt(jnp.maximum(1 - cos_theta * cos_theta, 0))
    sin_phi, cos_phi = sincos_turns(u2)  # φ = 2π u₂
    return jnp.stack([sin_theta * cos_phi, sin_theta * sin_phi, cos_theta], axis=-1)


def rotate(vectors, axes, cos_angle, sin_angle):
    """Rodrigues' rotation of `vectors` by the angle α about unit `axes`:

        R w = w cos α + (n × w) sin α + n (n · w)(1 − cos α).

    Args:
        vectors, axes: (3, ...) components first, broadcast against each other.
        cos_angle, sin_angle: cos α, sin α (scalars).
    Returns:
        (3, ...) rotated vectors (lengths preserved to round-off).
    """
    # Components first (structure of arrays): on XLA:CPU the rotation is faster than
    # with a trailing axis of length 3 (docs/performance_solvents.md).
    wx, wy, wz = vectors
    nx, ny, nz = axes
    along = (nx * wx + ny * wy + nz * wz) * (1 - cos_angle)
    return jnp.stack(
        [
            wx * cos_angle + (ny * wz - nz * wy) * sin_angle + nx * along,
            wy * cos_angle + (nz * wx - nx * wz) * sin_angle + ny * along,
            wz * cos_angle + (nx * wy - ny * wx) * sin_angle + nz * along,
        ]
    )


def srd_relative_velocities(
    frame_velocities, masses, cell, n_cells: int, key, cos_angle, sin_angle
):
    """The SRD rotation of the velocities relative to their cell's centre of mass.

    Args:
        frame_velocities: (N, 3) velocities as binned (jaxdpd.solvents.mpcd.cells.CellBinning).
        masses: (N,) masses, or None for unit masses.
        cell: (N,) int cell ids, each in [0, n_cells) (the gather relies on it:
            jaxdpd.solvents.mpcd.cells.cell_ids).
        n_cells: number of cells.
        key: uint32 collision key (axes per cell id).
        cos_angle, sin_angle: cos α, sin α.
    Returns:
        (relative, rotated): (3, N) each, components first: v_i − u_c before and
        R(n_c, α)(v_i − u_c) after the rotation.  The new velocity is
        v_i + (rotated − relative).
    """
    dtype = frame_velocities.dtype
    if masses is None:
        weights = jnp.ones(frame_velocities.shape[:1], dtype)
        momenta = frame_velocities
    else:
        weights = masses
        momenta = masses[:, None] * frame_velocities
    # One per-cell table (mass, momentum, axis), the axes written before the sums are
    # scattered in: the scatter's output is materialised, so each cell's axis is
    # hashed once.  Computed after the scatter, XLA fuses the hash into the gather
    # below and recomputes it for every particle and column (half the step).
    axes = random_axes(key, jnp.arange(n_cells, dtype=jnp.uint32), dtype)
    table = jnp.concatenate([jnp.zeros((n_cells, 4), dtype), axes], axis=1)
    table = table.at[cell, :4].add(jnp.concatenate([weights[:, None], momenta], axis=1))
    # Empty cells have zero mass; their (unused) mean is set to 0 instead of 0/0.
    cell_mass = table[:, :1]
    mean = table[:, 1:4] / jnp.where(cell_mass > 0, cell_mass, 1)
    # The ids are in range by construction (jaxdpd.solvents.mpcd.cells.cell_ids).
    per_cell = jnp.concatenate([mean, table[:, 4:]], axis=1).T
    per_particle = per_cell.at[:, cell].get(mode="promise_in_bounds")
    relative = frame_velocities.T - per_particle[:3]
    return relative, rotate(relative, per_particle[3:], cos_angle, sin_angle)


def single_particle_rotation(velocities, key, cos_angle, sin_angle):
    """The solvent-free Rouse variant (Mussawisade et al. §IV.A): the full velocity of
    every particle is rotated by α about its own random axis, drawn from (seed,
    collision index, particle index).  Each monomer's speed is kept; its mean velocity
    after a collision is (1 − γ_α) v, γ_α = (2/3)(1 − cos α) (eq. 9).

    Args:
        velocities: (N, 3).
        key: uint32 collision key.
        cos_angle, sin_angle: cos α, sin α.
    Returns:
        (N, 3) rotated velocities.
    """
    sites = jnp.arange(velocities.shape[0], dtype=jnp.uint32)
    axes = random_axes(key, sites, velocities.dtype)
    return rotate(velocities.T, axes.T, cos_angle, sin_angle).T


def maxwell_boltzmann_scaling(relative, masses, cell, n_cells: int, key, kT):
    """Cell-level Maxwell–Boltzmann scaling (MBS) thermostat of the relative velocities.

    Huang, Chatterji, Sutmann, Gompper & Winkler, J. Comput. Phys. 229, 168 (2010);
    compared with other cell thermostats under shear and Poiseuille flow by Huang,
    Varghese, Gompper & Winkler, Phys. Rev. E 91, 013310 (2015).  The relative
    velocities w_i = v_i − u_c of a cell of N_c particles, kinetic energy
    E_c = ½ Σ m_i w_i², are scaled by κ_c = (E'_c / E_c)^{1/2}, where E'_c is drawn
    from the canonical distribution of the kinetic energy of f = 3(N_c − 1) degrees
    of freedom, P(E) ∝ E^{f/2−1} exp(−E/k_BT).  Here E'_c = ½ k_BT χ²_f with
    χ²_f = Σ_{i∈c} |ξ_i − ξ̄_c|² from three standard normals ξ_i per particle (the
    sample-variance theorem), so one pass of cell sums draws every cell's energy.
    Momentum is untouched; cells with N_c ≤ 1 (E_c = 0) are left alone.

    Args:
        relative: (N, 3) relative velocities w_i (after the rotation).
        masses: (N,) masses or None (unit masses).
        cell: (N,) int cell ids.
        n_cells: number of cells.
        key: uint32 collision key (normals per particle index).
        kT: k_BT of the bath.
    Returns:
        (N, 3) scaled relative velocities κ_c w_i.
    """
    dtype = relative.dtype
    sites = jnp.arange(relative.shape[0], dtype=jnp.uint32)
    gaussians = jnp.stack(
        [
            noise.pair_gaussian(key, sites, sites, dtype, stream)
            for stream in THERMOSTAT_GAUSSIAN_STREAMS
        ],
        axis=1,
    )
    squares = relative * relative if masses is None else masses[:, None] * relative * relative
    columns = [
        jnp.ones_like(relative[:, :1]),
        gaussians,
        jnp.sum(gaussians * gaussians, axis=1, keepdims=True),
        jnp.sum(squares, axis=1, keepdims=True),
    ]
    totals = cell_totals(jnp.concatenate(columns, axis=1), cell, n_cells)
    count, gaussian_sum, gaussian_squares, twice_kinetic = (
        totals[:, 0],
        totals[:, 1:4],
        totals[:, 4],
        totals[:, 5],
    )
    chi_squared = gaussian_squares - jnp.sum(gaussian_sum**2, axis=1) / jnp.maximum(count, 1)
    # E'/E = k_BT χ² / (Σ m w²); a cell without relative motion keeps κ = 1.
    moving = twice_kinetic > 0
    ratio = (
        jnp.asarray(kT, dtype) * jnp.maximum(chi_squared, 0) / jnp.where(moving, twice_kinetic, 1)
    )
    scale = jnp.where(moving, jnp.sqrt(ratio), 1)
    return relative * scale[cell][:, None]


def collisional_virial(local, velocity_changes, masses):
    """Σ_i ξ_i ⊗ m_i Δv_i over all particles, (3, 3).

    ξ_i are the in-cell coordinates.  Since Σ_{i∈c} m_i Δv_i = 0 in every cell, the
    origin of ξ within a cell does not matter.  Divided by the collision time h and
    the volume it is the collisional part of the pressure tensor: the x-momentum a
    collision carries across a plane y = const, averaged over the plane's position
    in the cell, is Σ_{i∈c} ξ_{i,y} m_i Δv_{i,x} / a.  Its mean in a linear shear
    profile gives η_coll of Mussawisade et al. eq. 6 (see tests/test_mpcd_transport).
    """
    momenta = velocity_changes if masses is None else masses[:, None] * velocity_changes
    return dyadic_sum(local, momenta)


def srd_collision(
    grid,
    rotation_angle: float,
    masses,
    thermostat_kT,
    with_virial: bool,
    dtype,
    random_shift: bool = True,
    binning=bin_particles,
):
    """The SRD collision of all particles, optionally with the MBS thermostat.

    Args:
        grid: jaxdpd.solvents.mpcd.cells.CollisionGrid.
        rotation_angle: α in radians.
        masses: (N,) masses or None (unit masses).
        thermostat_kT: k_BT of the MBS thermostat, or None for none (the collision
            then conserves each cell's kinetic energy).
        with_virial: also return the collisional virial Σ ξ ⊗ m Δv (else zeros).
        dtype: floating dtype.
        random_shift: shift the grid at random before each collision (always, in
            scenes); False gives the original fixed-grid SRD (Malevanets & Kapral
            1999), which is not Galilean invariant at small mean free paths (Ihle &
            Kroll 2001) — a reference for tests.
        binning: how the box's particles are sorted into cells
            (jaxdpd.solvents.mpcd.cells.bin_particles, or the lattice cells of
            jaxdpd.solvents.mpcd.lattice_cells).
    Returns:
        `collide(bound_box, positions, velocities, key) -> (velocities, virial)`:
        the box bound to its state at the collision, positions (N, 3) wrapped, key the
        uint32 collision key (grid shift and axes); virial None unless `with_virial`.
    """
    cos_angle = jnp.asarray(math.cos(rotation_angle), dtype)
    sin_angle = jnp.asarray(math.sin(rotation_angle), dtype)
    n_cells = grid.n_cells

    def collide(bound_box, positions, velocities, key):
        if random_shift:
            shift = grid_shift(key, grid.cell_size, dtype)
        else:
            shift = jnp.zeros(3, dtype)
        binned = binning(grid, bound_box, positions, velocities, shift)
        relative, rotated = srd_relative_velocities(
            binned.frame_velocities, masses, binned.cell, n_cells, key, cos_angle, sin_angle
        )
        if thermostat_kT is not None:
            rotated = maxwell_boltzmann_scaling(
                rotated.T, masses, binned.cell, n_cells, key, thermostat_kT
            ).T
        changes = (rotated - relative).T
        virial = collisional_virial(binned.local, changes, masses) if with_virial else None
        return velocities + changes, virial

    return collide


def rouse_collision(rotation_angle: float, dtype):
    """The solvent-free Rouse variant as a collision (`single_particle_rotation`).

    Returns:
        `collide(bound_box, positions, velocities, key) -> (velocities, None)`: the
        rotation exchanges momentum with an implicit bath, not between particles, so
        it has no collisional stress.
    """
    cos_angle = jnp.asarray(math.cos(rotation_angle), dtype)
    sin_angle = jnp.asarray(math.sin(rotation_angle), dtype)

    def collide(bound_box, positions, velocities, key):
        del bound_box, positions
        return single_particle_rotation(velocities, key, cos_angle, sin_angle), None

    return collide
