"""Throughput of the lattice-Boltzmann solvent: lattice updates per second (MLUPS)
against the memory-bandwidth bound, and bead steps per second of a coupled chain.

LB: a fluid of n³ nodes (a = τ = ρ = 1, ν = 0.1), deterministic or thermal (uniform or
Gaussian noise on the 15 non-conserved modes), stepped in jitted `lax.scan` chunks
after a warm-up chunk.  The bound: one LB step must read and write the 19 population
deviations of a node and write its 3 velocity components, (19 + 19 + 3) values, plus
read the 3 impulse components; the copy bandwidth B is measured in the same run by a
jitted scan of `x + 1` over an array of the population's size (read + write), so
MLUPS_bound = B / (44 · bytes per value) and the ratio MLUPS / MLUPS_bound is what
the machine's load does not change much.

Beads: the packaged scene jaxdpd/scenes/lb_chain.toml, one Kremer–Grest chain of
N = 30 in 18³ nodes with the parameters of Ahlrichs & Dünweg (1999, Table I: τ = 0.05,
Δt = 0.01), all-pairs WCA list; MD steps/s and bead-steps/s, compilation excluded.

Usage:
    python benchmarks/lattice_boltzmann_throughput.py [--sizes 32 64] [--steps 50]
        [--precisions float32 float64] [--output lattice_boltzmann_throughput]
Writes benchmarks/results/<output>.json.
"""

import argparse
import time
from importlib import resources

import jax
import jax.numpy as jnp
import numpy as np
from _common import copy_bandwidth, print_table, timed, write_json

import jaxdpd
from jaxdpd.engine.build import build
from jaxdpd.run import driver
from jaxdpd.scene import Scene
from jaxdpd.solvents.lattice_boltzmann import counter_noise
from jaxdpd.solvents.lattice_boltzmann.fluid import (
    FluidParameters,
    lattice_update,
    thermal_deviations,
)

VALUES_PER_UPDATE = 19 + 19 + 3 + 3
CHAIN_SCENE = resources.files("jaxdpd.scenes").joinpath("lb_chain.toml")


def lattice_rate(n: int, precision: str, noise: str, steps: int) -> dict:
    dtype = jnp.dtype(precision)
    kT = 0.0 if noise == "off" else 1e-4
    fluid = FluidParameters((n, n, n), 1.0, 1.0, 1.0, 0.1, 0.1, kT)
    update = lattice_update(fluid, dtype, "uniform" if noise == "off" else noise)
    impulse = jnp.zeros((3, n, n, n), dtype)

    @jax.jit
    def run(deviations, first):
        def body(f, lb_step):
            key = counter_noise.family_key(1, lb_step, counter_noise.LATTICE_SALT)
            return update(f, impulse, key)[0], None

        return jax.lax.scan(body, deviations, first + jnp.arange(steps))[0]

    deviations = jnp.asarray(thermal_deviations(fluid, np.random.default_rng(0), dtype))
    start = time.perf_counter()
    deviations = run(deviations, 0).block_until_ready()
    compile_seconds = time.perf_counter() - start
    _, seconds = timed(run, deviations, steps)
    mlups = n**3 * steps / seconds / 1e6
    bandwidth = copy_bandwidth((19, n, n, n), dtype, steps)
    bound = bandwidth / (VALUES_PER_UPDATE * dtype.itemsize) / 1e6
    return {
        "nodes": n**3,
        "precision": precision,
        "noise": noise,
        "MLUPS": mlups,
        "copy_GB_per_s": bandwidth / 1e9,
        "bound_MLUPS": bound,
        "fraction_of_bound": mlups / bound,
        "compile_s": compile_seconds,
    }


def chain_rate(precision: str, steps: int) -> dict:
    scene = Scene.from_toml(CHAIN_SCENE).replace(precision=precision, output={"observables": []})
    simulation = build(scene)
    state = simulation.init_fn()
    start = time.perf_counter()
    state, _, _ = driver.run_chunk(simulation, state, steps)
    compile_seconds = time.perf_counter() - start
    start = time.perf_counter()
    state, _, _ = driver.run_chunk(simulation, state, steps)
    seconds = time.perf_counter() - start
    md_rate = steps / seconds
    return {
        "precision": precision,
        "md_steps_per_s": md_rate,
        "bead_steps_per_s": 30 * md_rate,
        "lattice_MLUPS": 18**3 * md_rate / 5 / 1e6,
        "compile_s": compile_seconds,
    }


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--sizes", type=int, nargs="+", default=[32, 64])
    parser.add_argument("--steps", type=int, default=50)
    parser.add_argument("--precisions", nargs="+", default=["float32", "float64"])
    parser.add_argument("--chain-steps", type=int, default=5000)
    parser.add_argument("--output", default="lattice_boltzmann_throughput", help="results name")
    args = parser.parse_args()
    jaxdpd.enable_float64()  # float64 lattices are made here, before any build
    rows = [
        lattice_rate(n, precision, noise, args.steps)
        for n in args.sizes
        for precision in args.precisions
        for noise in ("off", "uniform", "gaussian")
    ]
    print_table(
        ["nodes", "precision", "noise", "MLUPS", "bound_MLUPS", "fraction_of_bound", "compile_s"],
        rows,
    )
    chains = [chain_rate(precision, args.chain_steps) for precision in args.precisions]
    print()
    print_table(
        ["precision", "md_steps_per_s", "bead_steps_per_s", "lattice_MLUPS", "compile_s"], chains
    )
    path = write_json(args.output, {"lattice": rows, "chain": chains, "args": vars(args)})
    print(f"\nwrote {path}")


if __name__ == "__main__":
    main()
