"""The Lowe–Andersen sweep does not depend on how particles are laid out in rows.

A decomposed run (jaxdpd.decomposition) sweeps a device's rows: its own particles in
no particular order, free rows between them, copies of its neighbours'.  The sweep
is Lowe's sequential algorithm in the order of the pairs' keys (Lowe, Europhys.
Lett. 47, 145 (1999); tests/test_lowe_andersen_sweep.py checks that against a
sequential reference), and the keys, the selection and the Gaussian targets are
functions of the particles' identities, so the same particles in shuffled rows
among free rows must end with bit-identical velocities: each pair's update is the
same arithmetic on the same operands, in the same order.
"""

from typing import NamedTuple

import jax
import jax.numpy as jnp
import numpy as np

from jaxdpd.engine import noise
from jaxdpd.engine.ownership import Ownership
from jaxdpd.geometry.boxes import PeriodicBox
from jaxdpd.solvents import lowe_andersen as la

N, DENSITY, KT, DT, CUTOFF = 240, 3.0, 1.3, 0.01, 1.0
SIDE = (N / DENSITY) ** (1 / 3)
BOX = PeriodicBox((SIDE, SIDE, SIDE))
KEY = noise.step_key(seed=5, step=17)


class Pairs(NamedTuple):
    """The part of a PairList the thermostat reads: rows padded with the row count."""

    i: jnp.ndarray
    j: jnp.ndarray


def close_pairs(positions, rows_of):
    """Each pair within r_c + 0.2 once (brute force), as rows via `rows_of`, padded."""
    separation = positions[:, None] - positions[None]
    separation -= SIDE * np.round(separation / SIDE)
    close = np.triu(np.linalg.norm(separation, axis=-1) < CUTOFF + 0.2, 1)
    i, j = np.nonzero(close)
    padding = np.full(25, len(rows_of))
    return Pairs(*(jnp.asarray(np.concatenate([rows_of[x], padding]), jnp.int32) for x in (j, i)))


def test_shuffled_rows_among_free_rows_sweep_bit_identically():
    rng = np.random.default_rng(4)
    positions = rng.uniform(size=(N, 3)) * SIDE
    velocities = rng.normal(size=(N, 3))
    thermalize = la.lowe_andersen_thermostat(N, 1.0, KT, CUTOFF, DT, jnp.float64, True)
    identity_order = jnp.arange(N)
    reference, record = jax.jit(thermalize, static_argnums=0)(
        BOX,
        jnp.asarray(positions),
        jnp.asarray(velocities),
        close_pairs(positions, identity_order),
        KEY,
    )
    # The same particles in 400 rows, shuffled, free rows (identity −1) between them.
    rows = 400
    row_of_particle = rng.permutation(rows)[:N]
    identities = np.full(rows, -1)
    identities[row_of_particle] = np.arange(N)
    laid_out = {name: np.zeros((rows, 3)) for name in ("positions", "velocities")}
    laid_out["positions"][row_of_particle] = positions
    laid_out["velocities"][row_of_particle] = velocities
    lookup = jnp.asarray(row_of_particle, jnp.int32)
    ownership = Ownership(
        owned=jnp.asarray(identities >= 0),
        identities=jnp.asarray(identities, jnp.int32),
        row_of=lambda wanted: lookup[wanted],
    )
    shuffled = la.lowe_andersen_thermostat(
        N, 1.0, KT, CUTOFF, DT, jnp.float64, True, ownership=ownership
    )
    result, shuffled_record = jax.jit(shuffled, static_argnums=0)(
        BOX,
        jnp.asarray(laid_out["positions"]),
        jnp.asarray(laid_out["velocities"]),
        close_pairs(positions, row_of_particle),
        KEY,
    )
    np.testing.assert_array_equal(np.asarray(result)[row_of_particle], reference)
    assert int(shuffled_record.thermalized_pairs) == int(record.thermalized_pairs) > 0
    assert int(shuffled_record.rounds) == int(record.rounds) > 1
    # The test can fail: pairs keyed by rows instead of identities go in another order.
    by_rows, _ = jax.jit(
        la.lowe_andersen_thermostat(rows, 1.0, KT, CUTOFF, DT, jnp.float64, True),
        static_argnums=0,
    )(
        BOX,
        jnp.asarray(laid_out["positions"]),
        jnp.asarray(laid_out["velocities"]),
        close_pairs(positions, row_of_particle),
        KEY,
    )
    assert np.abs(np.asarray(by_rows)[row_of_particle] - reference).max() > 1e-3


def test_more_rows_than_the_sort_key_holds_sort_on_two_keys_in_the_same_order():
    """Half-edges are sorted by (row, order key), one uint64 per half-edge while the
    row fits beside the key; beyond (N ≥ 2^16 particles: 17 index bits and 30
    priority bits leave 17 for the row, fewer than 140000 rows need) two keys."""
    n, rows, pairs = 70000, 140000, 3000
    rng = np.random.default_rng(5)
    identities = np.full(rows, -1)
    held = rng.permutation(rows)[:n]
    identities[held] = np.arange(n)
    first, second = (held[rng.integers(0, n, pairs)] for _ in range(2))
    keep = first != second
    first, second = first[keep], second[keep]
    chosen = rng.uniform(size=first.size) < 0.7
    order_keys = la.pair_order_keys(
        KEY, jnp.asarray(identities[first]), jnp.asarray(identities[second]), n
    )
    inverse = np.zeros(n, np.int32)
    inverse[identities[held]] = held
    ownership = Ownership(
        identities=jnp.asarray(identities, jnp.int32), row_of=lambda x: jnp.asarray(inverse)[x]
    )
    edges = la._half_edges(
        jnp.asarray(first), jnp.asarray(second), jnp.asarray(chosen), order_keys, n, rows, ownership
    )
    # Reference: every selected pair's two half-edges, sorted by (owner row, key).
    owners = np.concatenate([first[chosen], second[chosen]])
    partners = np.concatenate([second[chosen], first[chosen]])
    keys = np.concatenate([np.asarray(order_keys)[chosen]] * 2)
    order = np.lexsort((keys, owners))
    count = owners.size
    np.testing.assert_array_equal(np.asarray(edges.i)[:count], owners[order])
    np.testing.assert_array_equal(np.asarray(edges.j)[:count], partners[order])
    np.testing.assert_array_equal(
        np.asarray(edges.tie_break)[:count], identities[owners[order]] ^ identities[partners[order]]
    )
    assert np.all(np.asarray(edges.i)[count:] >= rows)
    counts = np.bincount(owners, minlength=rows)
    np.testing.assert_array_equal(np.asarray(edges.stop), np.cumsum(counts))
