"""Where the lattice-Boltzmann step's time goes: wall time per XLA operation.

Times a jitted scan of LB steps shaped as benchmarks/lattice_boltzmann_throughput.py
times it (populations carried, density and velocity unused) with
thunk_profile.thunk_times, and prints the costliest operations in ms per LB step;
their names are those of the fusions in the optimised HLO, which `--hlo PATH`
writes out.

Usage:
    python benchmarks/lattice_boltzmann_profile.py [--size 64] [--noise off|uniform]
        [--precision float32] [--steps 10] [--top 12] [--hlo PATH]
"""

import argparse
import time
from pathlib import Path

import jax
import jax.numpy as jnp
import numpy as np
from thunk_profile import report, thunk_times

import jaxdpd
from jaxdpd.solvents.lattice_boltzmann import counter_noise
from jaxdpd.solvents.lattice_boltzmann.fluid import FluidParameters, lattice_update


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--size", type=int, default=64)
    parser.add_argument("--noise", choices=["off", "uniform", "gaussian"], default="off")
    parser.add_argument("--precision", default="float32")
    parser.add_argument("--steps", type=int, default=10)
    parser.add_argument("--top", type=int, default=12)
    parser.add_argument("--hlo", type=Path)
    args = parser.parse_args()
    jaxdpd.enable_float64()
    n, dtype = args.size, jnp.dtype(args.precision)
    kT = 0.0 if args.noise == "off" else 1e-4
    fluid = FluidParameters((n, n, n), 1.0, 1.0, 1.0, 0.1, 0.1, kT)
    update = lattice_update(fluid, dtype, "uniform" if args.noise == "off" else args.noise)
    rng = np.random.default_rng(0)
    impulse = jnp.asarray(1e-3 * rng.standard_normal((3, n, n, n)), dtype)
    start = jnp.asarray(1e-2 * rng.standard_normal((19, n, n, n)), dtype)

    @jax.jit
    def run(deviations):
        def body(f, lb_step):
            key = counter_noise.family_key(1, lb_step, counter_noise.LATTICE_SALT)
            return update(f, impulse, key)[0], None

        return jax.lax.scan(body, deviations, jnp.arange(args.steps))[0]

    jax.block_until_ready(run(start))
    begin = time.perf_counter()
    jax.block_until_ready(run(start))
    mlups = n**3 * args.steps / (time.perf_counter() - begin) / 1e6
    totals = thunk_times(run, start)
    print(f"{n}^3 {args.precision} noise={args.noise}: {mlups:.1f} MLUPS unprofiled,", end=" ")
    report(totals, args.steps, args.top)
    if args.hlo:
        args.hlo.write_text(run.lower(start).compile().as_text())


if __name__ == "__main__":
    main()
