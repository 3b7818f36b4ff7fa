"""jaxdpd's boxes, cell list and SLLOD streaming used from jax-md
(jaxdpd.interop.jax_md).

References:
- separations: a brute-force search over the periodic images of the lattice, in
  float64, with the lattice written from the total strain independently of jaxdpd's
  reduced basis: Lees–Edwards a1 = (L_x, 0, 0), a2 = (γ L_y mod L_x, L_y, 0),
  a3 = (0, 0, L_z) (thesis eq. 3.19); Kraynik–Reinelt the thesis's basis F(ε) A0 at
  ε = E mod ε_p (thesis §3.4.2, table 3.27), the shortest of n ∈ [−4, 4]² in-plane
  and n_y ∈ {−1, 0, 1} images (the search range is checked to contain it);
- forces: jax-md's `energy.soft_sphere` U = ε/α (1 − r/σ)^α (α = 2: the DPD
  conservative force, thesis eq. 2.4), F_i = Σ_j (ε/σ)(1 − r/σ) r̂_ij over the
  brute-force shortest images;
- pair sets: jax-md's own `partition.neighbor_list(..., format=Dense)` with
  `space.periodic` in a box at rest, the brute-force search in deformed boxes.

Float32 tolerance on forces: a displacement is off by a few ulp of the box edge
(positions, the float32 box state), so a force by ~10 ulp(L) ε/σ² per partner, at
most 30 partners here; a wrong image is off by O(ε/σ).
"""

import itertools
import math

import jax
import jax.numpy as jnp
import numpy as np
import pytest
from jax_md import energy, partition
from jax_md import space as jmd_space

from jaxdpd.engine import noise
from jaxdpd.engine.build import PairContext
from jaxdpd.forces.pair_sums import pair_geometry, pair_sums
from jaxdpd.geometry import flows
from jaxdpd.geometry.boxes import KraynikReineltState, LeesEdwardsState, make_box
from jaxdpd.geometry.boxes.kraynik_reinelt_lattice import stretch
from jaxdpd.interop.jax_md import neighbor_list, sllod, space
from jaxdpd.solvents.groot_warren import groot_warren_term

LE_LENGTHS = (6.0, 5.0, 5.0)
KR_LENGTHS = (6.0, 5.0, 6.0)
SIGMA = 2.0  # soft-sphere range: below half the thinnest cell height of both boxes
SEARCH = 4
SHEAR_STRAINS = [0.0, 0.3, 0.5, 1.7, 12.345, 1000.37, 1_000_000.61, 3_141_592.65]
# Around the changes of reduced basis (±0.2406 for case 1), near the thesis basis's
# thinnest cell (ε → ε_p), and far past 10⁶.
HENCKY_STRAINS = [0.0, 0.2, 0.2406058, 0.2406060, -0.4, 0.48, 0.9, 3.1, 1000.1, 1_000_000.93]


def lees_edwards(strain, dtype):
    """The box, its state at shear strain γ (offset γ L_y reduced in float64), and the
    reference lattice (3, 3), columns a1, a2, a3."""
    box = make_box("lees_edwards", LE_LENGTHS)
    lx, ly, lz = LE_LENGTHS
    offset = math.remainder(strain * ly, lx)  # in [−L_x/2, L_x/2]
    state = LeesEdwardsState(
        offset=jnp.asarray(offset, dtype),
        shear_rate=jnp.asarray(0.0, dtype),
        time=jnp.asarray(0.0, jnp.float64),
    )
    return box, state, np.array([[lx, offset, 0.0], [0.0, ly, 0.0], [0.0, 0.0, lz]])


def kraynik_reinelt(strain, dtype):
    """The box, its state at Hencky strain E (reduced modulo ε_p in float64), and the
    thesis lattice F(ε) A0 at ε = E mod ε_p."""
    box = make_box("kraynik_reinelt", KR_LENGTHS)
    period = box.period
    reduced = math.fmod(strain, period) % period  # in [0, ε_p): the thesis's interval
    state = KraynikReineltState(
        strain=jnp.asarray(math.remainder(reduced, period), dtype),
        elongation_rate=jnp.asarray(0.0, dtype),
    )
    side, ly, _ = KR_LENGTHS
    plane = stretch(reduced) @ (side * np.asarray(box.geometry.cell))
    lattice = np.array(
        [[plane[0, 0], 0.0, plane[0, 1]], [0.0, ly, 0.0], [plane[1, 0], 0.0, plane[1, 1]]]
    )
    return box, state, lattice


BOXES = {
    "lees_edwards": (lees_edwards, SHEAR_STRAINS),
    "kraynik_reinelt": (kraynik_reinelt, HENCKY_STRAINS),
}


def shortest_images(positions, lattice):
    """(N, N, 3) float64 shortest image vectors r_i − r_j + n · lattice."""
    ranges = [range(-SEARCH, SEARCH + 1), (-1, 0, 1), range(-SEARCH, SEARCH + 1)]
    if lattice[0, 2] == 0 and lattice[2, 0] == 0:  # Lees–Edwards: z is orthogonal
        ranges[2] = (-1, 0, 1)
    shifts = np.array(list(itertools.product(*ranges))) @ lattice.T
    raw = positions[:, None, :] - positions[None, :, :]
    best = np.full(raw.shape, np.inf)
    for shift in shifts:
        image = raw + shift
        shorter = np.sum(image**2, -1) < np.sum(best**2, -1)
        best[shorter] = image[shorter]
    reach = min(np.linalg.norm(lattice, axis=0)) * (SEARCH - 1)
    assert np.max(np.linalg.norm(best, axis=-1)) < reach, "widen the image search"
    return best


def brute_force_forces(positions, lattice, epsilon=1.0):
    """Soft-sphere (α = 2) forces from the shortest images, float64."""
    d = shortest_images(positions, lattice)
    r = np.linalg.norm(d, axis=-1)
    np.fill_diagonal(r, np.inf)
    magnitude = np.where(r < SIGMA, epsilon / SIGMA * (1 - r / SIGMA), 0.0)
    return np.sum((magnitude / r)[..., None] * d, axis=1), int(np.max(np.sum(r < SIGMA, 1)))


def brute_force_pairs(positions, lattice, cutoff):
    d = shortest_images(positions, lattice)
    close = np.sum(d * d, -1) < cutoff * cutoff
    return {(i, j) for i, j in zip(*np.nonzero(np.triu(close, 1)), strict=True)}


def listed(neighbors, n):
    """Unordered pairs of a jax-md list in any format."""
    idx = np.asarray(neighbors.idx)
    if neighbors.format is partition.Dense:
        rows = np.repeat(np.arange(n), idx.shape[1])
        pairs = zip(rows, idx.reshape(-1), strict=True)
    else:
        pairs = zip(idx[0], idx[1], strict=True)
    return {(min(i, j), max(i, j)) for i, j in pairs if i < n and j < n}


def random_positions(lattice, n, seed, dtype):
    """Uniform positions in the cell spanned by `lattice` (float64 and `dtype`)."""
    fractions = np.random.default_rng(seed).uniform(0, 1, (n, 3))
    positions = fractions @ lattice.T
    return positions, jnp.asarray(positions, dtype)


@pytest.mark.parametrize("kind", list(BOXES))
def test_jax_md_forces_with_jaxdpd_spaces_match_brute_force_in_float32(kind):
    """jax-md's soft-sphere pair energy over all pairs, differentiated by jax, with
    jaxdpd's displacement at every strain of the list (past 10⁶ strain units)."""
    make, strains = BOXES[kind]
    box, _, _ = make(0.0, jnp.float32)
    displacement, _ = space(box)
    energy_fn = energy.soft_sphere_pair(displacement, sigma=SIGMA, epsilon=1.0, alpha=2.0)
    force_fn = jax.jit(lambda r, state: -jax.grad(energy_fn)(r, box=state))
    tolerance = 30 * 10 * np.spacing(np.float32(max(box.lengths))) / SIGMA**2
    for k, strain in enumerate(strains):
        _, state, lattice = make(strain, jnp.float32)
        exact_positions, positions = random_positions(lattice, 60, k, jnp.float32)
        exact, partners = brute_force_forces(exact_positions, lattice)
        assert 3 < partners <= 30
        forces = np.asarray(force_fn(positions, state), np.float64)
        error = np.max(np.abs(forces - exact))
        assert error < tolerance, (strain, error, tolerance)


def test_neighbor_list_matches_jax_md_brute_force_on_a_periodic_box():
    """Every format of the cell-list neighbour list holds the pairs of jax-md's own
    Dense list without cell list (all pairs tested), at allocation and after an update
    that rebuilds."""
    box = make_box("periodic", (7.0, 7.0, 7.0))
    sides = jnp.asarray(box.lengths)
    displacement, shift = jmd_space.periodic(sides)
    reference_fns = partition.neighbor_list(
        displacement, sides, 1.0, dr_threshold=0.3, format=partition.Dense, disable_cell_list=True
    )
    rng = np.random.default_rng(3)
    positions = jnp.asarray(rng.uniform(0, 7.0, (400, 3)))
    moved = shift(positions, jnp.asarray(rng.normal(0, 0.2, (400, 3))))
    reference = reference_fns.allocate(positions)
    expected = listed(reference, 400)
    expected_moved = listed(reference_fns.update(moved, reference), 400)
    assert len(expected) > 1000 and expected_moved != expected
    for fmt in (partition.Sparse, partition.Dense, partition.OrderedSparse):
        fns = neighbor_list(box, 1.0, dr_threshold=0.3, format=fmt)
        neighbors = fns.allocate(positions)
        assert listed(neighbors, 400) == expected, fmt
    # One format through a rebuilding update (each costs a compilation), then into an
    # overflow: the same particles squeezed into an eighth of the box.
    update = jax.jit(fns.update)
    refreshed = update(moved, neighbors)
    assert not refreshed.did_buffer_overflow
    assert listed(refreshed, 400) == expected_moved
    assert update(0.5 * positions, neighbors).did_buffer_overflow


@pytest.mark.parametrize("kind", list(BOXES))
def test_neighbor_list_and_jax_md_energy_in_deformed_boxes_match_brute_force(kind):
    """In sheared and elongated boxes at two strains (one past 10⁶): the listed pairs
    are the brute-force pairs within r_cutoff + dr_threshold, and jax-md's
    soft_sphere_neighbor_list energy over them gives the brute-force forces (float32)."""
    make, strains = BOXES[kind]
    box, _, _ = make(0.0, jnp.float32)
    displacement, shift = space(box)
    _, energy_fn = energy.soft_sphere_neighbor_list(
        displacement, jnp.asarray(box.lengths), sigma=SIGMA, epsilon=1.0, alpha=2.0
    )
    force_fn = jax.jit(lambda r, nbrs, state: -jax.grad(energy_fn)(r, nbrs, box=state))
    fns = neighbor_list(box, SIGMA, dr_threshold=0.2)
    tolerance = 30 * 10 * np.spacing(np.float32(max(box.lengths))) / SIGMA**2
    for k, strain in enumerate([strains[3], strains[-1]]):
        _, state, lattice = make(strain, jnp.float32)
        raw = random_positions(lattice, 60, 10 + k, jnp.float32)[1]
        positions = shift(raw, jnp.zeros_like(raw), box=state)  # into the primary cell
        exact_positions = np.asarray(positions, np.float64)
        neighbors = fns.allocate(positions, box=state)
        assert listed(neighbors, 60) == brute_force_pairs(exact_positions, lattice, SIGMA + 0.2)
        forces = np.asarray(force_fn(positions, neighbors, state), np.float64)
        exact, _ = brute_force_forces(exact_positions, lattice)
        assert np.max(np.abs(forces - exact)) < tolerance, strain


# Three allocations and two compilations of the vmapped cell list (~100 s on the
# shared 2 cores): -m slow.  The default run flags an overflow in the periodic test.
@pytest.mark.slow
def test_overflow_is_flagged_and_a_batch_reallocates_under_vmap():
    """Two sheared replicas (own offsets) updated under vmap: squeezing one into half
    the box overflows its list only; `allocate` on the batch gives one shape that holds
    both, whose vmapped update lists the brute-force pairs with no overflow."""
    box, _, _ = lees_edwards(0.0, jnp.float64)
    fns = neighbor_list(box, 1.0, dr_threshold=0.2)
    states, lattices = zip(*[lees_edwards(s, jnp.float64)[1:] for s in (0.4, 7.9)], strict=True)
    batch_state = jax.tree.map(lambda *leaves: jnp.stack(leaves), *states)
    positions = jnp.stack(
        [random_positions(lat, 200, 20 + b, jnp.float64)[1] for b, lat in enumerate(lattices)]
    )
    _, shift = space(box)
    positions = jax.vmap(lambda r, s: shift(r, jnp.zeros_like(r), box=s))(positions, batch_state)
    neighbors = fns.allocate(positions, box=batch_state)
    update = jax.jit(jax.vmap(lambda r, nbrs, s: fns.update(r, nbrs, box=s)))
    squeezed = positions.at[1].multiply(0.5)  # stays in the primary box
    flagged = update(squeezed, neighbors, batch_state)
    assert list(np.asarray(flagged.did_buffer_overflow) != 0) == [False, True]
    neighbors = fns.allocate(squeezed, box=batch_state)
    refreshed = update(squeezed, neighbors, batch_state)
    assert not np.any(np.asarray(refreshed.did_buffer_overflow))
    for b, lattice in enumerate(lattices):
        replica = jax.tree.map(lambda leaf, b=b: leaf[b], refreshed)
        expected = brute_force_pairs(np.asarray(squeezed[b]), lattice, 1.2)
        assert listed(replica, 200) == expected


def test_sllod_streams_free_particles_with_the_shear_flow():
    """Without forces SLLOD keeps c = 0 and moves each particle with the flow,
    x(t) = x0 + γ̇ (y0 − L_y/2) t (thesis eqs. 3.42–3.43), re-entering across the moving
    boundary with the offset; the box clock advances the offset by γ̇ L_y t (mod L_x).
    Reference: those formulas in float64, wrapped by the brute-force lattice."""
    shear_rate, dt, steps = 0.3, 0.05, 400
    box = make_box("lees_edwards", LE_LENGTHS)
    box = type(box)(LE_LENGTHS, shear_rate)
    start = np.random.default_rng(5).uniform(0, 1, (20, 3)) * LE_LENGTHS
    init_fn, apply_fn = sllod(lambda r, **kwargs: jnp.zeros_like(r), box, dt)
    state = init_fn(jax.random.PRNGKey(0), jnp.asarray(start), velocity=jnp.zeros((20, 3)))
    state = jax.lax.fori_loop(0, steps, lambda _, s: apply_fn(s), state)
    time = steps * dt
    lx, ly, _ = LE_LENGTHS
    expected_offset = math.remainder(shear_rate * ly * time, lx)
    assert abs(float(state.box.offset) - expected_offset) < 1e-10
    _, _, lattice = lees_edwards(shear_rate * time, jnp.float64)
    travelled = start.copy()
    travelled[:, 0] += shear_rate * (start[:, 1] - ly / 2) * time
    # Same point of the lattice: the difference is a lattice vector.
    fractions = np.linalg.solve(lattice, (np.asarray(state.position) - travelled).T)
    assert np.max(np.abs(fractions - np.round(fractions))) < 1e-10
    assert np.max(np.abs(np.asarray(state.velocity))) == 0.0


def dpd_force_fn(box, a, gamma, kT, dt, seed):
    """Groot–Warren DPD written against the interop interfaces: the conservative force
    from jax-md's soft sphere (α = 2, σ = r_c = 1, ε = a: U = a (1 − r)²/2, thesis
    eq. 2.4) through jaxdpd's space, the dissipative and random forces from jaxdpd's
    thermostat term on the neighbour list's pairs.  Returns (force_fn, virial_fn)."""
    displacement, _ = space(box)
    _, energy_fn = energy.soft_sphere_neighbor_list(
        displacement, jnp.asarray(box.lengths), sigma=1.0, epsilon=a, alpha=2.0
    )
    thermostat = groot_warren_term(gamma, kT, dt, "uniform", jnp.float32)
    identity = jnp.eye(3)

    def thermostat_sums(R, neighbor, state, velocity, step):
        geometry = pair_geometry(box.bind(state), R, neighbor.pair_list, 1.0, half=True)
        context = PairContext(velocity, None, noise.step_key(seed, step))
        return pair_sums(geometry, thermostat(geometry, context), with_virial=True)

    def force_fn(R, neighbor, box, velocity, step):
        conservative = -jax.grad(energy_fn)(R, neighbor, box=box)
        return conservative + thermostat_sums(R, neighbor, box, velocity, step)[0]

    def virial_fn(R, neighbor, state, velocity, step):
        """Σ_pairs r_ij ⊗ F_ij (thesis eq. 3.46): the conservative part as jax-md's
        stress does it, −∂U/∂ε of separations deformed by I + ε."""

        def deformed(strain):
            return energy_fn(R, neighbor, box=state, perturbation=identity + strain)

        conservative = -jax.grad(deformed)(jnp.zeros((3, 3), R.dtype)).T
        return conservative + sum(thermostat_sums(R, neighbor, state, velocity, step)[1].values())

    return force_fn, virial_fn


# Two 3500-step runs of 1500 DPD particles (~5 min on the shared 2 cores): -m slow.
@pytest.mark.slow
def test_dpd_sheared_through_jax_md_matches_jaxdpd_viscosity_and_profile():
    """The DPD fluid (ρ = 3, a = 25, γ = 4.5, k_BT = 1, Δt = 0.04, λ = 0.65) sheared at
    γ̇ = 0.5 twice from the same start: by jaxdpd's own engine, and by the interop
    SLLOD integrator with jax-md's soft-sphere force, jaxdpd's space and neighbour list
    and the DPD thermostat on its pairs.  The interop run's laboratory profile is
    γ̇ (y − L_y/2) in every slab (mean peculiar c_x zero within 4 standard errors of
    20 block averages), and the viscosities −⟨P_xy⟩/γ̇ agree within 4 combined
    standard errors (independent noise: different integrator splitting of the seed)."""
    from conftest import make_scene

    from jaxdpd.analysis.statistics import block_average
    from jaxdpd.engine.build import build
    from jaxdpd.run import driver

    shear_rate, dt, lam, equilibrate, steps, every = 0.5, 0.04, 0.65, 500, 3000, 5
    scene = make_scene(
        precision="float32",
        particles={"density": 3.0, "count": 1500},
        integrator={"dt": dt, "lambda": lam},
        flow={"kind": "shear", "shear_rate": shear_rate},
        output={"observables": ["pressure"]},
    )
    simulation = build(scene)
    start = simulation.init_fn()
    parts = []
    state = driver.run(simulation, start, equilibrate, 500)
    driver.run(simulation, state, steps, 500, on_chunk=lambda r: parts.append(r.series))
    jaxdpd_stress = -np.concatenate([np.asarray(p["pressure_tensor"])[:, 0, 1] for p in parts])

    box = make_box("lees_edwards", scene.box.lengths, scene.flow)
    force_fn, virial_fn = dpd_force_fn(box, 25.0, 4.5, 1.0, dt, seed=11)
    fns = neighbor_list(box, 1.0, dr_threshold=0.3)
    init_fn, apply_fn = sllod(force_fn, box, dt, lambda_=lam, velocity_dependent=True)
    box_state = box.initial_state(jnp.float32)
    neighbors = fns.allocate(start.positions, box=box_state)
    state = init_fn(
        jax.random.PRNGKey(0),
        start.positions,
        velocity=start.velocities,
        box=box_state,
        neighbor=neighbors,
    )
    volume, bins = box.volume, 6

    def step(carry, _):
        state, neighbors = carry
        bound = box.bind(state.box)
        predicted = state.velocity + lam * dt * (
            state.force + flows.sllod_drag(bound, state.velocity)
        )
        neighbors = fns.update(state.position, neighbors, box=state.box)
        new = apply_fn(state, neighbor=neighbors)
        neighbors = fns.update(new.position, neighbors, box=new.box)
        return (new, neighbors), (predicted, new)

    @jax.jit
    def chunk(state, neighbors):
        def sample(carry, _):
            (state, neighbors), (predicted, new) = jax.lax.scan(step, carry, None, every)
            predicted, new = predicted[-1], jax.tree.map(lambda leaf: leaf[-1], new)
            velocity = new.velocity
            kinetic = velocity.T @ velocity
            virial = virial_fn(new.position, neighbors, new.box, predicted, new.step)
            slab = jnp.floor(new.position[:, 1] / box.lengths[1] * bins).astype(jnp.int32)
            counts = jnp.zeros(bins).at[slab].add(1.0)
            mean_cx = jnp.zeros(bins).at[slab].add(velocity[:, 0]) / counts
            return (state, neighbors), (-(kinetic + virial)[0, 1] / volume, mean_cx)

        return jax.lax.scan(sample, (state, neighbors), None, 100)

    stress, profile = [], []
    for k in range((equilibrate + steps) // (100 * every)):
        (state, neighbors), (s, p) = chunk(state, neighbors)
        assert not neighbors.did_buffer_overflow
        if k >= equilibrate // (100 * every):
            stress.append(np.asarray(s))
            profile.append(np.asarray(p))
    stress, profile = np.concatenate(stress), np.concatenate(profile)

    mean_cx, mean_cx_error = block_average(profile, n_blocks=20)
    assert np.all(np.abs(mean_cx) < 4 * mean_cx_error), (mean_cx, mean_cx_error)
    eta, eta_error = (v / shear_rate for v in block_average(stress, n_blocks=20))
    eta_ref, eta_ref_error = (v / shear_rate for v in block_average(jaxdpd_stress, n_blocks=20))
    print("η interop", eta, "±", eta_error, "η jaxdpd", eta_ref, "±", eta_ref_error)
    assert abs(eta - eta_ref) < 4 * np.hypot(eta_error, eta_ref_error)


def test_flowing_boxes_refuse_calls_without_their_state_and_too_long_cutoffs():
    """A forgotten box state is an error (or NaN from the displacement, which jax-md
    probes for its shape); a cut-off plus skin beyond half the thinnest cell height is
    refused (the minimum image would be ambiguous)."""
    box, state, _ = lees_edwards(0.3, jnp.float64)
    displacement, shift = space(box)
    r = jnp.ones((4, 3))
    assert np.all(np.isnan(np.asarray(displacement(r[0], r[1]))))
    assert np.all(np.isfinite(np.asarray(displacement(r[0], r[1], box=state))))
    with pytest.raises(TypeError, match="shift_fn.*lees_edwards"):
        shift(r, r)
    with pytest.raises(TypeError, match="allocate.*lees_edwards"):
        neighbor_list(box, 1.0).allocate(r)
    half = min(box.cell_heights) / 2
    with pytest.raises(ValueError, match="r_cutoff \\+ dr_threshold"):
        neighbor_list(box, half - 0.1, dr_threshold=0.2)
    with pytest.raises(ValueError, match="format"):
        neighbor_list(box, 1.0, format="dense")


def test_sllod_streams_free_particles_with_planar_elongation_across_resets():
    """Without forces each particle follows the flow, r(t) − r0 = F(ε̇t)(r(0) − r0),
    F = diag(e^−ε, 1, e^ε) (thesis eq. 5.12), through two Kraynik–Reinelt resets
    (ε̇t = 2 > 2 ε_p), up to a lattice vector of the thesis lattice at that strain.
    Tolerance: velocity Verlet streams with 1 + ΔtL + ½Δt²L², off e^{ΔtL} by
    (ε̇Δt)³/6 per step (jaxdpd.geometry.flows), accumulated over the steps."""
    rate, dt, steps = 0.5, 0.01, 400
    box = make_box("kraynik_reinelt", KR_LENGTHS)
    box = type(box)(KR_LENGTHS, rate)
    _, _, lattice = kraynik_reinelt(0.0, jnp.float64)
    start, _ = random_positions(lattice, 20, 6, jnp.float64)
    centre = np.asarray(box.centre)
    init_fn, apply_fn = sllod(lambda r, **kwargs: jnp.zeros_like(r), box, dt)
    state = init_fn(jax.random.PRNGKey(0), jnp.asarray(start), velocity=jnp.zeros((20, 3)))
    state = jax.lax.fori_loop(0, steps, lambda _, s: apply_fn(s), state)
    strain = rate * dt * steps
    assert abs(float(state.box.strain) - math.remainder(strain, box.period)) < 1e-12
    _, _, lattice = kraynik_reinelt(strain, jnp.float64)
    stretched = centre + (start - centre) * np.exp([-strain, 0.0, strain])
    fractions = np.linalg.solve(lattice, (np.asarray(state.position) - stretched).T)
    reach = np.max(np.abs(stretched - centre)) / min(box.cell_heights)
    tolerance = 2 * steps * (rate * dt) ** 3 / 6 * reach
    assert np.max(np.abs(fractions - np.round(fractions))) < tolerance
    assert np.max(np.abs(fractions)) >= 1  # the resets did move particles back
