"""The parallel Lowe–Andersen sweep equals Lowe's sequential algorithm exactly.

Reference: Lowe, Europhys. Lett. 47, 145 (1999); thesis §2.3.2, table 2.1 step 2
and eqs. 2.19–2.21 (with the reduced mass μ_ij for unequal masses), and eq. 3.47 for
the impulse virial Σ r_ij ⊗ m_i Δv_i / Δt.  The reference below visits the selected
pairs one at a time in the order of their keys, in plain NumPy over all pairs found
by brute force; it shares with jaxdpd only the counter-based random numbers
(selection, order keys, Gaussian targets), which are the algorithm's inputs.
"""

import functools
from typing import NamedTuple

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from jaxdpd.engine import noise
from jaxdpd.geometry.boxes import LeesEdwardsBox, PeriodicBox
from jaxdpd.solvents import lowe_andersen as la

N, DENSITY, KT, DT, CUTOFF = 240, 3.0, 1.3, 0.01, 1.0
SIDE = (N / DENSITY) ** (1 / 3)
BOX = PeriodicBox((SIDE, SIDE, SIDE))
KEY = noise.step_key(seed=5, step=17)
# Two species: the first 80 particles of mass 1, the rest of mass 3.
MASSES = np.where(np.arange(N) < 80, 1.0, 3.0)
SHEAR_RATE = 0.7


def periodic_separation(separation):
    """Minimum image in the periodic box, (..., 3)."""
    return separation - SIDE * np.round(separation / SIDE)


def sheared_box():
    """A Lees–Edwards box at offset 1.3 (images across y shifted in x), bound."""
    box = LeesEdwardsBox((SIDE, SIDE, SIDE), SHEAR_RATE, None)
    return box, box.initial_state(jnp.float64).set(offset=jnp.asarray(1.3))


def sheared_separation(separation):
    """Minimum image across the moving boundary (the box's own rule, thesis eq.
    3.19; tested in tests/test_lees_edwards_geometry.py)."""
    box, state = sheared_box()
    return np.asarray(box.bind(state).minimum_image_vectors(jnp.asarray(separation)))


@pytest.fixture(scope="module")
def configuration():
    rng = np.random.default_rng(3)
    positions = rng.uniform(size=(N, 3)) * SIDE
    velocities = rng.normal(size=(N, 3)) / np.sqrt(MASSES)[:, None]
    return positions, velocities


class Pairs(NamedTuple):
    """The part of a PairList the thermostat reads: indices padded with N."""

    i: jnp.ndarray
    j: jnp.ndarray


@pytest.fixture(scope="module")
def pair_lists(configuration):
    """A half list (each pair once, as jaxdpd's cell list) and a full list (each
    pair twice, as jax-md's dense and sparse formats) of the pairs within r_c + 0.2,
    found by brute force and padded with N, like the neighbour backends' lists."""
    positions = configuration[0]
    lists = {}
    for name, separate in (("periodic", periodic_separation), ("sheared", sheared_separation)):
        separation = separate(positions[:, None] - positions[None])
        close = np.linalg.norm(separation, axis=-1) < CUTOFF + 0.2
        np.fill_diagonal(close, False)
        padding = np.full(25, N)
        for kind, pairs in (("half", np.triu(close)), ("full", close)):
            i, j = np.nonzero(pairs)
            lists[name, kind] = Pairs(
                *(jnp.asarray(np.concatenate([x, padding]), jnp.int32) for x in (i, j))
            )
    return {"half": lists["periodic", "half"], "full": lists["periodic", "full"], **lists}


def sequential_sweep(
    positions, velocities, masses, probability, reverse=False, separate=periodic_separation
):
    """Lowe's algorithm pair by pair, in increasing order key (decreasing if reverse).

    With `separate = sheared_separation` the velocities are peculiar velocities c in
    a simple shear u = γ̇ (y − L_y/2) x̂, and the pair's laboratory relative velocity
    is c_i − c_j + γ̇ Δy x̂ with Δy the y component of the minimum image, which
    includes the jump γ̇ L_y x̂ across the moving boundary (thesis eq. 3.18).

    Returns:
        (velocities after the sweep, impulse virial Σ r_ij ⊗ μ Δu e_ij / Δt,
        number of thermalised pairs).
    """
    i, j = np.triu_indices(N, 1)
    separation = separate(positions[i] - positions[j])
    shear_rate = SHEAR_RATE if separate is sheared_separation else 0.0
    distance = np.linalg.norm(separation, axis=1)
    near = distance < CUTOFF
    i, j, separation, distance = i[near], j[near], separation[near], distance[near]
    chosen = np.asarray(la.selected(KEY, jnp.asarray(i), jnp.asarray(j), probability, jnp.float64))
    i, j, separation, distance = i[chosen], j[chosen], separation[chosen], distance[chosen]
    order = np.argsort(np.asarray(la.pair_order_keys(KEY, jnp.asarray(i), jnp.asarray(j), N)))
    reduced = masses[i] * masses[j] / (masses[i] + masses[j])
    target = np.asarray(
        la.target_relative_velocity(
            KEY, jnp.asarray(i), jnp.asarray(j), KT, jnp.asarray(reduced), jnp.float64
        )
    )
    v = velocities.copy()
    virial = np.zeros((3, 3))
    for q in order[::-1] if reverse else order:
        a, b = i[q], j[q]
        e = separation[q] / distance[q]
        laboratory = v[a] - v[b] + np.array([shear_rate * separation[q, 1], 0, 0])
        impulse = reduced[q] * (target[q] - laboratory @ e)
        v[a] += impulse / masses[a] * e
        v[b] -= impulse / masses[b] * e
        virial += np.outer(separation[q], impulse * e) / DT
    return v, virial, len(i)


@functools.cache
def compiled_thermostat(probability: float, half: bool, with_masses: bool):
    """One jitted thermalisation per variant, shared by the tests."""
    thermalize = la.lowe_andersen_thermostat(
        N,
        probability,
        KT,
        CUTOFF,
        DT,
        jnp.float64,
        half,
        jnp.asarray(MASSES) if with_masses else None,
        with_virial=True,
    )
    return jax.jit(thermalize, static_argnums=0)  # the periodic box is static


def thermalized(pair_list, half, configuration, probability, with_masses):
    positions, velocities = (jnp.asarray(x) for x in configuration)
    thermalize = compiled_thermostat(probability, half, with_masses)
    return thermalize(BOX, positions, velocities, pair_list, KEY)


# Tolerance: float64 round-off of O(10) sequential updates of O(1) velocities per
# particle (a few 1e-16 each), with a wide margin; the virial sums ~10³ terms of O(10³).
VELOCITY_TOLERANCE = 1e-12
VIRIAL_TOLERANCE = 1e-9


@pytest.mark.parametrize(
    ("probability", "with_masses"), [(0.3, False), (1.0, True)], ids=["p0.3-unit", "p1-masses"]
)
def test_parallel_rounds_equal_the_sequential_sweep(
    configuration, pair_lists, probability, with_masses
):
    masses = MASSES if with_masses else np.ones(N)
    velocities, record = thermalized(
        pair_lists["half"], True, configuration, probability, with_masses
    )
    expected, virial, count = sequential_sweep(*configuration, masses, probability)
    np.testing.assert_allclose(velocities, expected, rtol=0, atol=VELOCITY_TOLERANCE)
    np.testing.assert_allclose(record.impulse_virial, virial, rtol=0, atol=VIRIAL_TOLERANCE)
    assert int(record.thermalized_pairs) == count
    # Momentum is exchanged within pairs only: Σ m v is unchanged to round-off.
    momentum = masses @ np.asarray(configuration[1])
    np.testing.assert_allclose(masses @ np.asarray(velocities), momentum, rtol=0, atol=1e-12)
    # The comparison can fail: the same pairs swept in the opposite order end elsewhere.
    reversed_order, _, _ = sequential_sweep(*configuration, masses, probability, reverse=True)
    assert np.abs(reversed_order - expected).max() > 1e3 * VELOCITY_TOLERANCE
    # Rounds: at least one, at most one per pair; each round applies a batch of pairs.
    assert 1 <= int(record.rounds) < count


def test_result_does_not_depend_on_the_neighbour_list(configuration, pair_lists):
    """The order keys and random numbers depend on (seed, step, i, j) only, so a full
    list, a half list and a shuffled half list give bit-identical velocities."""
    half_list = pair_lists["half"]
    reference, _ = thermalized(half_list, True, configuration, 1.0, True)
    velocities, _ = thermalized(pair_lists["full"], False, configuration, 1.0, True)
    np.testing.assert_array_equal(velocities, reference)
    permutation = np.random.default_rng(0).permutation(half_list.i.shape[0])
    shuffled = Pairs(half_list.j[permutation], half_list.i[permutation])
    velocities, _ = thermalized(shuffled, True, configuration, 1.0, True)
    np.testing.assert_array_equal(velocities, reference)


def test_order_key_layout():
    """A uint64 holds owner | priority | i XOR j: 32 priority bits up to N = 65535."""
    assert la.order_key_bits(65535) == (16, 32)
    assert la.order_key_bits(1_000_000) == (20, 24)
    i = jnp.asarray([3, 7, 7], jnp.int32)
    j = jnp.asarray([7, 3, 9], jnp.int32)
    keys = np.asarray(la.pair_order_keys(KEY, i, j, 100))
    assert keys[0] == keys[1]  # symmetric in (i, j)
    assert keys[0] & 127 == 3 ^ 7 and keys[2] & 127 == 7 ^ 9


def test_vmapped_sweeps_equal_single_sweeps(configuration, pair_lists):
    """vmap over step keys (the replicas of an ensemble) gives each replica's own
    sweep: the round loop runs until every replica is done, and a finished
    replica's extra rounds change nothing."""
    positions, velocities = (jnp.asarray(x) for x in configuration)
    keys = jnp.stack([noise.step_key(5, step) for step in (17, 18, 19)])
    thermalize = compiled_thermostat(1.0, True, True)
    batched, records = jax.vmap(
        lambda key: thermalize(BOX, positions, velocities, pair_lists["half"], key)
    )(keys)
    for k, key in enumerate(keys):
        single, record = thermalize(BOX, positions, velocities, pair_lists["half"], key)
        np.testing.assert_array_equal(batched[k], single)
        assert int(records.rounds[k]) == int(record.rounds)


def test_sheared_sweep_uses_laboratory_relative_velocities(configuration, pair_lists):
    """In a Lees–Edwards box the thermostat acts on laboratory relative velocities
    (thesis §3.4 and eq. 3.18) while the stored velocities are peculiar: the sweep
    equals the sequential reference with c_i − c_j + γ̇ Δy x̂, pairs across the
    moving boundary included."""
    box, state = sheared_box()
    thermalize = la.lowe_andersen_thermostat(N, 1.0, KT, CUTOFF, DT, jnp.float64, True)
    positions, velocities = (jnp.asarray(x) for x in configuration)
    sheared = jax.jit(
        lambda box_state, pairs: thermalize(box.bind(box_state), positions, velocities, pairs, KEY)[
            0
        ]
    )(state, pair_lists["sheared", "half"])
    expected, _, _ = sequential_sweep(*configuration, np.ones(N), 1.0, separate=sheared_separation)
    np.testing.assert_allclose(sheared, expected, rtol=0, atol=VELOCITY_TOLERANCE)
    # The flow's part matters: without it (a box at rest) the result differs.
    at_rest, _, _ = sequential_sweep(*configuration, np.ones(N), 1.0)
    assert np.abs(at_rest - expected).max() > 1e3 * VELOCITY_TOLERANCE
