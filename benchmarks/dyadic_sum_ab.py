"""Dyadic sums as reductions (jaxdpd.dyadic) against the matrix products they replaced.

Every jaxdpd module that uses `dyadic_sum` or `dyadic_square` (kinetic tensor,
virials, conformation tensors) is given the matrix-product form `a.T @ b` while a step
compiles, then the library's own; the two compiled chunks of each scene run in
alternating rounds in one process from the same state.  Scenes: the MPCD fluid of
benchmarks/mpcd_throughput.py (temperature observed) and the Groot–Warren fluid of
benchmarks/dpd_throughput.py (temperature and pressure observed, equilibrated by the
driver).  Prints the rate of each, their ratio, whether the trajectories are
bit-identical, and the largest difference of the samples relative to their scale.

    python benchmarks/dyadic_sum_ab.py [--mpcd-size 100000] [--dpd-size 24000]
        [--steps 20] [--rounds 8]
"""

import argparse
import statistics

import jax
import numpy as np
from _common import alternating_rates, compiled_chunk, ratio_summary
from dpd_throughput import equilibrated_fluid, fluid_scene
from mpcd_throughput import solvent_scene

import jaxdpd.decomposition.forces
import jaxdpd.engine.integrators
import jaxdpd.forces.bonds
import jaxdpd.forces.spring_repulsion
import jaxdpd.observables.domain_chains
import jaxdpd.observables.thermo
import jaxdpd.solvents.mpcd.collision

# Every module that uses dyadic_sum or dyadic_square: imported here, so that none is first imported
# while a base chunk compiles, and each given the form under test by name.
USERS = (
    jaxdpd.decomposition.forces,
    jaxdpd.engine.integrators,
    jaxdpd.forces.bonds,
    jaxdpd.forces.spring_repulsion,
    jaxdpd.observables.domain_chains,
    jaxdpd.observables.thermo,
    jaxdpd.solvents.mpcd.collision,
)


def matrix_product(a, b):
    """Σ_i a_i ⊗ b_i as the product of the transposed rows: the form before dyadic_sum."""
    return a.reshape(-1, a.shape[-1]).T @ b.reshape(-1, b.shape[-1])


def matrix_square(a, weights=None):
    """Σ_i w_i a_i ⊗ a_i in the same matrix-product form."""
    return matrix_product(a if weights is None else weights[..., None] * a, a)


def sample_difference(samples, reference) -> float:
    """Largest |difference| of any sample over that sample's largest |value|."""
    pairs = zip(jax.tree.leaves(samples), jax.tree.leaves(reference), strict=True)
    return max(
        float(np.max(np.abs(np.asarray(a, np.float64) - np.asarray(b, np.float64))))
        / max(float(np.max(np.abs(np.asarray(b, np.float64)))), 1e-300)
        for a, b in pairs
    )


def compare(label: str, scene, state, steps: int, rounds: int) -> None:
    forms = {"dyadic_sum": matrix_product, "dyadic_square": matrix_square}
    replacements = [
        (module, name, form)
        for module in USERS
        for name, form in forms.items()
        if hasattr(module, name)
    ]
    base, state = compiled_chunk(scene, state, steps, replacements)
    this, _ = compiled_chunk(scene, state, steps)
    (base_state, base_samples), (this_state, this_samples) = base(state), this(state)
    identical = np.array_equal(
        np.asarray(base_state.velocities), np.asarray(this_state.velocities)
    ) and np.array_equal(np.asarray(base_state.positions), np.asarray(this_state.positions))
    rates = alternating_rates(
        {"base": lambda: base(state), "this": lambda: this(state)},
        scene.n_particles * steps,
        rounds,
    )
    print(
        f"{label}, N = {scene.n_particles}: trajectory bit-identical: {identical}; samples "
        f"differ by {sample_difference(this_samples, base_samples):.1e} of their scale; "
        f"matrix product {statistics.median(rates['base']):.3g}/s, reductions "
        f"{statistics.median(rates['this']):.3g}/s, {ratio_summary(rates)}"
    )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--mpcd-size", type=int, default=100_000)
    parser.add_argument("--dpd-size", type=int, default=24_000)
    parser.add_argument("--steps", type=int, default=20)
    parser.add_argument("--rounds", type=int, default=8)
    args = parser.parse_args()
    compare("MPCD", solvent_scene(args.mpcd_size, "float32"), None, args.steps, args.rounds)
    _, fluid = equilibrated_fluid(args.dpd_size)
    compare("DPD", fluid_scene(args.dpd_size, "float32"), fluid, args.steps, args.rounds)


if __name__ == "__main__":
    main()
