"""The lattice-Boltzmann update of this tree against another tree's, in one process.

Loads jaxdpd/solvents/lattice_boltzmann/fluid.py from `--base` (a checkout of the
revision to compare with, e.g. made by `git worktree add /tmp/base main`) and from
this tree, checks that both give bit-identical populations, densities and velocities
over a jitted scan of `--steps` LB steps (a = τ = ρ = 1, ν = 0.1, a random impulse
field), then times the two scans alternately, round after round, so that the load of
a shared machine hits both alike.  Prints the MLUPS of each and the per-round ratio
this/base: the ratios' spread is the noise a difference must exceed.

Usage:
    python benchmarks/lattice_boltzmann_ab.py --base /tmp/base [--size 64]
        [--noise off|uniform|gaussian] [--precision float32] [--steps 20] [--rounds 8]
"""

import argparse
from pathlib import Path

import jax
import jax.numpy as jnp
import numpy as np
from _common import alternating_rates, module_from_file, ratio_summary

import jaxdpd
from jaxdpd.solvents.lattice_boltzmann import counter_noise

FLUID = Path("jaxdpd/solvents/lattice_boltzmann/fluid.py")
HERE = Path(__file__).resolve().parent.parent


def scan_runner(fluid_module, parameters, dtype, noise: str, impulse, steps: int):
    """jit(f, first_step) -> (f, (Σρ, Σu) per step) of `steps` LB updates."""
    update = fluid_module.lattice_update(parameters, dtype, "uniform" if noise == "off" else noise)

    @jax.jit
    def run(deviations, first):
        def body(f, lb_step):
            key = counter_noise.family_key(1, lb_step, counter_noise.LATTICE_SALT)
            f, density, velocity = update(f, impulse, key)
            return f, (density, velocity)

        return jax.lax.scan(body, deviations, first + jnp.arange(steps))

    return run


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--base", type=Path, required=True)
    parser.add_argument("--size", type=int, default=64)
    parser.add_argument("--noise", choices=["off", "uniform", "gaussian"], default="off")
    parser.add_argument("--precision", default="float32")
    parser.add_argument("--steps", type=int, default=20)
    parser.add_argument("--rounds", type=int, default=8)
    args = parser.parse_args()
    jaxdpd.enable_float64()
    dtype, n = jnp.dtype(args.precision), args.size
    base = module_from_file(args.base / FLUID, "base_fluid")
    this = module_from_file(HERE / FLUID, "this_fluid")
    kT = 0.0 if args.noise == "off" else 1e-4
    parameters = this.FluidParameters((n, n, n), 1.0, 1.0, 1.0, 0.1, 0.1, kT)
    rng = np.random.default_rng(0)
    impulse = jnp.asarray(1e-3 * rng.standard_normal((3, n, n, n)), dtype)
    start = jnp.asarray(1e-2 * rng.standard_normal((19, n, n, n)), dtype)
    runs = {
        label: scan_runner(module, parameters, dtype, args.noise, impulse, args.steps)
        for label, module in (("base", base), ("this", this))
    }
    results = {label: jax.device_get(run(start, 0)) for label, run in runs.items()}
    leaves = [jax.tree.leaves(results[label]) for label in runs]
    identical = all(np.array_equal(a, b) for a, b in zip(*leaves, strict=True))
    rates = alternating_rates(
        {label: lambda run=run: run(start, 0) for label, run in runs.items()},
        n**3 * args.steps / 1e6,
        args.rounds,
    )
    print(f"{n}^3 {args.precision} noise={args.noise}: bit-identical={identical}")
    for label in runs:
        print(f"  {label}: median {np.median(rates[label]):.1f} MLUPS")
    print(f"  {ratio_summary(rates)}")


if __name__ == "__main__":
    main()
