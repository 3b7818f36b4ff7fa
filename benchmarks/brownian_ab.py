"""Brownian dynamics step rate: this tree against a base tree, alternating in one process.

The base's `jaxdpd/brownian/springs.py` and `dynamics.py` are loaded as separate
modules beside this tree's (the checks they import are this tree's), and both
integrate the scene of benchmarks/brownian_throughput.py (FENE b = 50, shear De = 1, dt = 0.01,
float64) in alternating rounds, so that the machine's load hits both alike.

    git worktree add --detach /tmp/base <commit>
    python benchmarks/brownian_ab.py --base /tmp/base [--sizes 10000] [--rounds 6]
"""

import argparse
import statistics
import sys
from pathlib import Path

import jax
import jax.numpy as jnp
import numpy as np
from _common import alternating_rates, module_from_file, ratio_summary
from brownian_throughput import DE, DT, B

import jaxdpd
from jaxdpd.brownian import dynamics, springs, velocity_gradient


def load_base(root: Path):
    """The base tree's springs and dynamics modules, under other names; the base
    dynamics is bound to the base springs (its own root solver)."""
    modules = {}
    saved = sys.modules["jaxdpd.brownian.springs"]
    try:
        for name in ("springs", "dynamics"):
            path = root / "jaxdpd" / "brownian" / f"{name}.py"
            modules[name] = module_from_file(path, f"base_brownian_{name}")
            sys.modules["jaxdpd.brownian.springs"] = modules["springs"]
    finally:
        sys.modules["jaxdpd.brownian.springs"] = saved
    return modules["dynamics"], modules["springs"]


def runner(module, springs, n_steps: int, noise: str):
    """Jitted `run(key, q0) -> connectors` of `module.simulate` with `springs.FENE`."""
    kappa, spring = velocity_gradient("shear", DE), springs.FENE(B)

    @jax.jit
    def run(key, q0):
        state = module.state_from_connectors(q0, spring)
        final, _ = module.simulate(
            key, state, kappa, spring, DT, n_samples=1, sample_every=n_steps,
            observe=lambda c, s: None, noise=noise,
        )  # fmt: skip
        return final.connector

    return run


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--base", type=Path, required=True)
    parser.add_argument("--sizes", type=int, nargs="+", default=[10_000])
    parser.add_argument("--steps", type=int, default=200)
    parser.add_argument("--rounds", type=int, default=6)
    args = parser.parse_args()
    jaxdpd.enable_float64()
    base, base_springs = load_base(args.base)
    for n in args.sizes:
        q0 = jnp.asarray(0.5 * np.random.default_rng(0).standard_normal((n, 3)))
        key = jax.random.key(1)
        for noise in ("gaussian", "three_point"):
            runs = {
                "base": runner(base, base_springs, args.steps, noise),
                "this": runner(dynamics, springs, args.steps, noise),
            }
            for run in runs.values():
                jax.block_until_ready(run(key, q0))
            rates = alternating_rates(
                {name: lambda r=run, k=key, q=q0: r(k, q) for name, run in runs.items()},
                n * args.steps,
                args.rounds,
            )
            print(
                f"N = {n}, {noise}: base {statistics.median(rates['base']):.3g}/s, "
                f"this {statistics.median(rates['this']):.3g}/s, {ratio_summary(rates)}",
                flush=True,
            )


if __name__ == "__main__":
    main()
