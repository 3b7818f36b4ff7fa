"""How far a change of the LB step's floating-point order moves its trajectories.

Two measures, each printed as the largest |difference| over an array's largest
|value| (the relative deviation `tests/golden/record.py --check` reports):

1. The golden LB scenes (`lb_chain`, `lattice_boltzmann_wca_chain`: float64, 40 MD
   steps, 8 LB steps) run by the imported jaxdpd against their stored files:
   bead positions, velocities, forces and the samples.
2. The populations of a thermal 18³ float64 fluid (random impulse field, 40 LB steps)
   from the imported tree's `lattice_update` against those of `--base`'s.

`--reorder` makes the imported tree's mode transform m = E f sum the populations in
reverse order (the same sum, another rounding).  Run under the old code, that gives
the deviation of a harmless reordering, against which a new code's deviation is
judged:

    PYTHONPATH=<old tree> python benchmarks/lattice_boltzmann_roundoff.py \
        --base <old tree> --reorder        # old code, reordered, against old
    python benchmarks/lattice_boltzmann_roundoff.py --base <old tree>   # new against old
"""

import argparse
import sys
from pathlib import Path

import jax
import jax.numpy as jnp
import numpy as np
from lattice_boltzmann_ab import load_fluid

import jaxdpd
from jaxdpd.solvents.lattice_boltzmann import counter_noise
from jaxdpd.solvents.lattice_boltzmann import fluid as imported_fluid

sys.path.insert(0, str(Path(__file__).resolve().parent.parent / "tests"))
from golden import record  # noqa: E402

SCENES = ("lb_chain", "lattice_boltzmann_wca_chain")
KEYS = ("positions", "velocities", "forces")


def relative(old, new) -> float:
    """max |new − old| / max |old|."""
    old, new = np.asarray(old, np.float64), np.asarray(new, np.float64)
    return float(np.max(np.abs(new - old)) / max(np.max(np.abs(old)), 1e-300))


def reversed_modes(populations, *count):
    """The imported `modes`, summing the populations in reverse order."""
    order = np.arange(populations.shape[0])[::-1]
    basis = jnp.asarray(imported_fluid.MODE_BASIS[: count[0] if count else None], populations.dtype)
    return jnp.einsum("ki,i...->k...", basis[:, order], populations[order])


def golden_deviations() -> dict:
    """{scene: {key: relative deviation}} of the imported code against the stored runs."""
    result = {}
    for name in SCENES:
        stored = np.load(record.HERE / f"{name}.npz")
        arrays = record.run(record.SCENES[name])
        samples = [k for k in stored.files if k.startswith("sample") and stored[k].size]
        result[name] = {key: relative(stored[key], arrays[key]) for key in KEYS}
        result[name]["samples"] = max(relative(stored[k], arrays[k]) for k in samples)
    return result


def population_deviation(base_tree: Path, steps: int = 40, n: int = 18) -> float:
    """Relative deviation of the populations after `steps` thermal LB steps."""
    base = load_fluid(base_tree, "base_fluid")
    parameters = base.FluidParameters((n, n, n), 1.0, 1.0, 1.0, 0.1, 0.1, 1e-4)
    rng = np.random.default_rng(0)
    impulse = jnp.asarray(1e-3 * rng.standard_normal((3, n, n, n)))
    start = jnp.asarray(base.thermal_deviations(parameters, rng, jnp.float64))

    def trajectory(module):
        update = module.lattice_update(parameters, jnp.float64, "uniform")

        def body(f, lb_step):
            key = counter_noise.family_key(1, lb_step, counter_noise.LATTICE_SALT)
            return update(f, impulse, key)[0], None

        return jax.jit(lambda f: jax.lax.scan(body, f, jnp.arange(steps))[0])(start)

    return relative(trajectory(base), trajectory(imported_fluid))


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--base", type=Path, required=True)
    parser.add_argument("--reorder", action="store_true")
    args = parser.parse_args()
    jaxdpd.enable_float64()
    if args.reorder:
        imported_fluid.modes = reversed_modes
    print(f"jaxdpd from {Path(jaxdpd.__file__).parent.parent}, reorder={args.reorder}")
    for name, deviations in golden_deviations().items():
        print(f"  {name:28s} " + "  ".join(f"{k} {v:.1e}" for k, v in deviations.items()))
    populations = population_deviation(args.base)
    print(f"  populations (18³, 40 LB steps, against --base)  {populations:.1e}")
    print(f"  float64 ulp × 40 steps: {40 * np.finfo(np.float64).eps:.1e}")


if __name__ == "__main__":
    main()
