"""Why the Lowe–Andersen pairs are swept in sequence: the summed update overheats.

Lowe's algorithm (thesis table 2.1) visits the selected pairs one after another, each
pair seeing the velocities the pairs before it left.  A tempting parallel shortcut
computes every pair's update from the velocities before the sweep and adds them all:

    Δv_i = Σ_j ½ (u'_ij − u_ij) e_ij,   u_ij = (v_i − v_j)·e_ij before the sweep.

A particle with n selected partners then has its relative velocities corrected n
times over, which amplifies instead of resetting them once ΓΔt times the ~4πρ/3
neighbours per particle is a few.  This script applies both to an ideal gas (unit
masses, ρ = 3, k_BT = 1, r_T = 1) whose positions are drawn afresh before each sweep
(the ideal gas's equilibrium positions, independent of the velocities) and prints
the kinetic temperature after a number of sweeps.  The sequential sweep
(jaxdpd.solvents.lowe_andersen) leaves the Maxwell distribution invariant, so its
temperature stays at k_BT; the summed one drifts away or diverges.

Usage:
    python benchmarks/lowe_andersen_summed.py [--count 3000] [--sweeps 200]
        [--probabilities 0.1 0.5 1.0]
Writes benchmarks/results/lowe_andersen_summed.json.
"""

import argparse

import jax
import jax.numpy as jnp
import numpy as np
from _common import print_table, write_json

from jaxdpd.analysis.statistics import block_average
from jaxdpd.engine import noise
from jaxdpd.forces.pair_sums import accumulate, pair_geometry
from jaxdpd.geometry.boxes import PeriodicBox
from jaxdpd.geometry.neighbors import neighbor_search
from jaxdpd.solvents import lowe_andersen as la

DENSITY, KT, DT, CUTOFF = 3.0, 1.0, 0.01, 1.0


def summed_thermalization(box, probability, dtype):
    """The summed update above (NOT Lowe's algorithm; for comparison only)."""

    def thermalize(positions, velocities, pair_list, key):
        pairs = pair_geometry(box, positions, pair_list, CUTOFF, True)
        chosen = pairs.within & la.selected(key, pairs.i, pairs.j, probability, dtype)
        target = la.target_relative_velocity(key, pairs.i, pairs.j, KT, 0.5, dtype)
        change = jnp.where(chosen, 0.5 * (target - pairs.along_pair(velocities)), 0)
        return velocities + accumulate(pairs, change)

    return thermalize


def temperatures(thermalize, search, box, n: int, sweeps: int, pair_list, seed: int):
    """Kinetic temperature after each of `sweeps` sweeps, fresh positions each time
    (host function: checks that no neighbour buffer overflowed)."""
    lengths = jnp.asarray(box.lengths)

    def sweep(carry, step):
        velocities, pair_list = carry
        position_key = jax.random.fold_in(jax.random.PRNGKey(seed), step)
        positions = jax.random.uniform(position_key, (n, 3), jnp.float64) * lengths
        pair_list = search.update(positions, pair_list)
        velocities = thermalize(positions, velocities, pair_list, noise.step_key(seed, step))
        temperature = jnp.sum(velocities**2) / (3 * (n - 1))
        return (velocities, pair_list), (temperature, pair_list.overflow)

    @jax.jit
    def run(pair_list):
        start = jax.random.normal(jax.random.PRNGKey(seed + 1), (n, 3), jnp.float64)
        start = start - start.mean(axis=0)
        return jax.lax.scan(sweep, (start, pair_list), jnp.arange(sweeps))[1]

    series, overflow = run(pair_list)
    if np.any(overflow):
        raise RuntimeError("neighbour buffers overflowed; allocate more room")
    return np.asarray(series)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--count", type=int, default=3000)
    parser.add_argument("--sweeps", type=int, default=200)
    parser.add_argument("--probabilities", type=float, nargs="+", default=[0.1, 0.5, 1.0])
    args = parser.parse_args()
    n = args.count
    side = (n / DENSITY) ** (1 / 3)
    box = PeriodicBox((side, side, side))
    search = neighbor_search(box, n, CUTOFF, 0.0)
    rng = np.random.default_rng(0)
    # Room for an ideal gas's fluctuations: pairs 1.5 × their mean, cells far
    # beyond a Poisson maximum (mean occupancy ρ (L/⌊L/r_c⌋)³).
    cell_occupancy = DENSITY * (side / np.floor(side / CUTOFF)) ** 3
    minimum = (int(1.5 * n * DENSITY * 2 * np.pi / 3), int(3 * cell_occupancy + 15))
    positions = jnp.asarray(rng.uniform(size=(n, 3)) * side)
    pair_list = search.allocate(positions, 1.5, minimum)
    rows = []
    for probability in args.probabilities:
        sequential = la.lowe_andersen_thermostat(n, probability, KT, CUTOFF, DT, jnp.float64, True)

        def sequential_velocities(positions, velocities, pair_list, key, update=sequential):
            return update(box, positions, velocities, pair_list, key)[0]

        for name, thermalize in (
            ("sequential", sequential_velocities),
            ("summed", summed_thermalization(box, probability, jnp.float64)),
        ):
            series = temperatures(thermalize, search, box, n, args.sweeps, pair_list, 3)
            half = series[len(series) // 2 :]
            finite = np.all(np.isfinite(half))
            mean, error = block_average(half, n_blocks=10) if finite else (np.nan, np.nan)
            rows.append(
                {
                    "probability": probability,
                    "sweep": name,
                    "T_after_1": float(series[0]),
                    "T_after_10": float(series[9]),
                    "T_last": float(series[-1]),
                    "T_mean_second_half": float(mean),
                    "T_error": float(error),
                }
            )
            print_table(list(rows[-1]), rows[-1:])
    print()
    print_table(list(rows[0]), rows)
    payload = {"count": n, "sweeps": args.sweeps, "density": DENSITY, "rows": rows}
    print(f"wrote {write_json('lowe_andersen_summed', payload)}")


if __name__ == "__main__":
    jax.config.update("jax_enable_x64", True)
    main()
