"""The MPCD step: streaming, monomer sub-steps, collisions (Mussawisade et al. 2005 §II).

Invariants: momentum (always) and energy (no thermostat) are conserved by the whole
step; Galilean invariance from the random grid shift; monomer-only force kernels;
the MBS thermostat holds k_BT; error flags; float32 stays float32.
"""

import math

import jax
import jax.numpy as jnp
import numpy as np
import pytest
from mpcd_scenes import polymer_solution

from jaxdpd.analysis.dynamics import time_autocorrelation
from jaxdpd.analysis.statistics import block_average
from jaxdpd.engine import errors
from jaxdpd.engine.build import build
from jaxdpd.engine.integrators import mpcd_cycle
from jaxdpd.geometry.boxes import PeriodicBox
from jaxdpd.run import driver
from jaxdpd.scene import Scene
from jaxdpd.solvents.mpcd.cells import collision_grid
from jaxdpd.solvents.mpcd.collision import srd_collision

HOOKEAN = 3.0  # H = 3 k_BT/l² with l = 1 (seed eq. 3), as in tests/mpcd_scenes.py


PAIR_A = 25.0  # soft repulsion among monomers (with MPCD a [pair] acts among them only)


def polymer_scene(precision="float64", observables=("temperature",), pair=False, **solvent):
    """8 Gaussian chains of 10 monomers of mass M = ρm = 5 (the seed's choice) in 1000
    solvent particles (tests/mpcd_scenes.py); with `pair` a soft repulsion a = 25
    among the monomers (neighbour list over the monomers)."""
    # jax-md's dense list compiles in a third of the cell list's time for 80 particles.
    pair_section = (
        {
            "pair": {"kind": "soft_repulsion", "a": PAIR_A},
            "neighbors": {"method": "jax_md", "format": "dense"},
        }
        if pair
        else {}
    )
    return Scene.from_dict(
        polymer_solution(
            precision=precision,
            solvent=solvent,
            output={"observables": list(observables)},
            **pair_section,
        )
    )


def _monomer_geometry(state):
    """Minimum-image monomer separations (80, 80, 3), distances and spring vectors."""
    positions = np.asarray(state.positions, np.float64)[1000:]
    separations = positions[:, None] - positions[None]
    separations -= 6.0 * np.round(separations / 6.0)
    distances = np.linalg.norm(separations, axis=-1)
    np.fill_diagonal(distances, np.inf)
    springs = np.diff(positions.reshape(8, 10, 3), axis=1)
    springs -= 6.0 * np.round(springs / 6.0)
    return separations, distances, springs


def _energy(state, masses):
    """Kinetic energy + Hookean bonds + soft repulsion a r_c (1 − r/r_c)²/2 among
    monomers (each pair once)."""
    velocities = np.asarray(state.velocities, np.float64)
    kinetic = 0.5 * np.sum(masses[:, None] * velocities**2)
    _, distances, springs = _monomer_geometry(state)
    repulsion = 0.25 * PAIR_A * np.sum(np.clip(1 - distances, 0, None) ** 2)
    return kinetic + 0.5 * HOOKEAN * np.sum(springs**2) + repulsion


CHUNK = 50  # every run below has this length, so the compiled chunk is shared


@pytest.fixture(scope="module")
def polymer_run():
    scene = polymer_scene(pair=True)
    simulation = build(scene)
    first = simulation.init_fn()
    last, _, _ = driver.run_chunk(simulation, first, CHUNK)
    return scene, simulation, first, last


def test_step_conserves_momentum_and_energy_with_monomers(polymer_run):
    """50 collisions of solvent + monomers of mass 5 with springs and a soft repulsion
    among monomers: total momentum to round-off (collisions conserve it per cell,
    monomer forces are internal); total energy to the velocity-Verlet error of the
    monomer forces, bounded here by 10⁻³ of the chains' thermal energy (h_p ω ≤
    0.01 √((4H + 2a)/M) ≈ 0.04, relative error O((h_p ω)²))."""
    scene, simulation, first, last = polymer_run
    masses = np.asarray(simulation.masses)
    for state in (first, last):
        assert state.velocities.dtype == jnp.float64
    momentum = [masses @ np.asarray(s.velocities) for s in (first, last)]
    scale = masses @ np.abs(np.asarray(first.velocities))
    np.testing.assert_allclose(momentum[1], momentum[0], atol=1e-13 * scale.max())
    chain_energy = 80 * 1.5 + 72 * 1.5  # k_BT/2 per quadratic degree of freedom
    assert abs(_energy(last, masses) - _energy(first, masses)) < 1e-3 * chain_energy
    assert int(last.step) == 50 and float(last.time) == pytest.approx(50 * 0.1)
    assert not int(last.flags)
    # Solvent particles feel no force; monomers do.
    assert np.all(np.asarray(last.forces)[:1000] == 0)
    assert np.any(np.asarray(last.forces)[1000:] != 0)


def test_pair_forces_act_among_monomers_only(polymer_run):
    """A [pair] section with MPCD acts among the polymer species alone: the neighbour
    list holds the 80 monomers only, and the forces after 50 steps equal the chain
    springs plus the soft repulsion F_ij = a (1 − r/r_c) e_ij (Groot–Warren) among
    monomers, computed here by brute force over all monomer pairs."""
    _, _, _, last = polymer_run
    listed = np.asarray(last.pair_list.i)
    assert listed.max() == 80 and np.all(listed[listed < 80] >= 0)  # 80 = empty slot
    separations, distances, springs = _monomer_geometry(last)
    magnitude = np.where(distances < 1, PAIR_A * (1 - distances), 0)
    pair_forces = np.sum(magnitude[..., None] * separations / distances[..., None], axis=1)
    spring_forces = np.zeros((8, 10, 3))
    spring_forces[:, :-1] += HOOKEAN * springs
    spring_forces[:, 1:] -= HOOKEAN * springs
    expected = pair_forces + spring_forces.reshape(80, 3)
    np.testing.assert_allclose(np.asarray(last.forces)[1000:], expected, atol=1e-12)


SOLVENT_BOX = PeriodicBox((6.0, 6.0, 6.0))


def _solvent_step(random_shift=True):
    """The bare MPCD step of a solvent (α = 130°, h = 0.1, no monomers)."""
    collide = srd_collision(
        collision_grid(SOLVENT_BOX.lengths, 1.0),
        math.radians(130),
        None,
        None,
        False,
        jnp.float64,
        random_shift,
    )
    return mpcd_cycle(SOLVENT_BOX, 0.1, 1, None, None, collide, 1.0, jnp.float64)


def _solvent_state():
    """1080 solvent particles (ρ = 5 in a 6³ box), seed 3."""
    scene = Scene.from_dict(
        {
            "seed": 3,
            "precision": "float64",
            "box": {"lengths": list(SOLVENT_BOX.lengths)},
            "particles": {"density": 5.0},
            "solvent": {"method": "mpcd"},
            "output": {"observables": ["temperature"]},  # no virial, as _solvent_step
        }
    )
    return build(scene).init_fn()


def test_solvent_streams_freely_then_collides():
    """One step is r ← r + h v (eq. 1, wrapped into the box) with the velocities of the
    previous collision, then a collision that changes velocities only."""
    state = _solvent_state()
    after = jax.jit(_solvent_step())(state)
    expected = np.mod(np.asarray(state.positions) + 0.1 * np.asarray(state.velocities), 6.0)
    difference = np.abs(np.asarray(after.positions) - expected)
    np.testing.assert_allclose(np.minimum(difference, 6.0 - difference), 0, atol=1e-13)
    assert int(after.step) == 1 and float(after.time) == pytest.approx(0.1)
    assert np.mean(np.abs(np.asarray(after.velocities - state.velocities))) > 0.5


def _velocity_autocorrelation(drift, random_shift, steps=600):
    """Solvent VACF in the comoving frame, lags 0..10, with block standard errors.

    α = 130°, h = 0.1 (mean free path 0.1 a, where a fixed grid breaks Galilean
    invariance most), the same seed and initial configuration for every drift: only
    the velocities differ, by `drift`.
    """
    step = _solvent_step(random_shift)
    state = _solvent_state()
    state = state.set(velocities=state.velocities + jnp.asarray(drift))
    _, velocities = jax.jit(
        lambda s: jax.lax.scan(lambda c, _: (step(c), c.velocities), s, None, length=steps)
    )(state)
    peculiar = np.asarray(velocities) - np.asarray(drift)
    blocks = peculiar.reshape(10, steps // 10, *peculiar.shape[1:])
    per_block = np.stack(
        [np.asarray(time_autocorrelation(b))[:11].sum(-1).mean(-1) for b in blocks]
    )
    return block_average(per_block, n_blocks=10)


def test_random_shift_makes_the_dynamics_galilean_invariant():
    """Ihle & Kroll, Phys. Rev. E 63, 020201(R) (2001): with the random grid shift a
    uniform velocity U added to all particles changes nothing but the drift, so the
    comoving-frame VACF of the run with U = (1.3, 0.7, 0.4) equals that of U = 0 (same
    seed, same configuration) within errors: |difference| < 4 combined standard
    errors at every lag 1..10.  Negative control: a fixed grid fails the same test at
    λ = 0.1 a (particles linger in one cell when U = 0, not when U ≠ 0)."""
    drift = np.array([1.3, 0.7, 0.4])
    for random_shift, invariant in ((True, True), (False, False)):
        rest, rest_error = _velocity_autocorrelation(np.zeros(3), random_shift)
        moving, moving_error = _velocity_autocorrelation(drift, random_shift)
        z = np.abs(rest - moving)[1:] / np.hypot(rest_error, moving_error)[1:]
        if invariant:
            assert np.max(z) < 4, z
        else:
            assert np.max(z) > 6, z


def test_maxwell_boltzmann_thermostat_holds_the_temperature_in_float32():
    """With thermostat = "maxwell_boltzmann_scaling" a fluid started hot (velocities
    ×1.5, k_BT = 2.25) relaxes to the bath k_BT = 1 within a few collisions and its
    momentum is untouched.  The temperature of collisions 50–200 equals 1 within 5
    standard errors of its block average.  The scene is float32 and stays float32."""
    scene = polymer_scene("float32", ["temperature"], thermostat="maxwell_boltzmann_scaling")
    simulation = build(scene)
    state = simulation.init_fn()
    state = state.set(velocities=1.5 * state.velocities)
    masses = np.asarray(simulation.masses, np.float64)
    momentum = masses @ np.asarray(state.velocities, np.float64)
    temperatures = []
    for _ in range(4):
        state, samples, _ = driver.run_chunk(simulation, state, CHUNK)
        kinetic = np.asarray(samples["kinetic"], np.float64)
        temperatures.append(np.trace(kinetic, axis1=1, axis2=2) / (3 * (scene.n_particles - 1)))
    for array in (state.positions, state.velocities, state.forces, state.time):
        assert array.dtype == jnp.float32
    mean, error = block_average(np.concatenate(temperatures[1:]), n_blocks=10)
    assert abs(mean - 1.0) < 5 * error and error < 0.01, (mean, error)
    # float32 round-off: ~10 ε Σ m|v| over 200 collisions.
    scale = masses @ np.abs(np.asarray(state.velocities, np.float64))
    np.testing.assert_allclose(
        masses @ np.asarray(state.velocities, np.float64), momentum, atol=1e-4 * scale.max()
    )


def test_non_finite_velocities_stop_the_run(polymer_run):
    _, simulation, _, last = polymer_run
    state = last.set(velocities=last.velocities.at[5, 0].set(jnp.nan))
    with pytest.raises(errors.SimulationError, match="non-finite"):
        driver.run_chunk(simulation, state, CHUNK)
