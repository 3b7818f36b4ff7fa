"""Three ways to write the kinetic tensor Σ_i v_i ⊗ v_i, timed inside a jitted scan.

- "nine products": `jaxdpd.dyadic.dyadic_sum(v, v)`, the (3, 3, N) broadcast product
  reduced over the rows;
- "six stacked": the 6 distinct products stacked into a (6, N) array, one reduction;
- "six sums": `jaxdpd.dyadic.dyadic_square(v)`, each distinct product summed on its own.

Each form runs `--steps` times in a `lax.scan` that scales the velocities every step
(so nothing is hoisted out of the loop); "scale only" is that scan without the tensor.
The figure is ms per step, best of 7 calls, and the error is the largest deviation from
the float64 sum relative to the largest entry, in units of u = 2⁻²⁴.  float32, N
unit-variance velocities; runs on the default backend (CPU or GPU).

    python benchmarks/kinetic_tensor_forms.py [--sizes 106480] [--steps 20]
Writes benchmarks/results/kinetic_tensor_forms.json.
"""

import argparse

import jax
import jax.numpy as jnp
import numpy as np
from _common import best_of, print_table, write_json

from jaxdpd.dyadic import dyadic_square, dyadic_sum

PAIRS = ((0, 0), (0, 1), (0, 2), (1, 1), (1, 2), (2, 2))


def six_stacked(v):
    """The 6 distinct products of each row stacked into one (6, N) array, summed by one
    reduction, and mirrored into (3, 3)."""
    rows = v.T
    sums = jnp.sum(jnp.stack([rows[k] * rows[l] for k, l in PAIRS]), axis=-1)
    mirror = np.array([[0, 1, 2], [1, 3, 4], [2, 4, 5]])
    return sums[mirror]


FORMS = {
    "scale only": None,
    "nine products": lambda v: dyadic_sum(v, v),
    "six stacked": six_stacked,
    "six sums": dyadic_square,
}


def measure(n: int, steps: int) -> list[dict]:
    velocities = jnp.asarray(np.random.default_rng(0).standard_normal((n, 3)), jnp.float32)
    rows = []
    for name, form in FORMS.items():

        def body(v, _, form=form):
            v = v * jnp.float32(0.999)
            return v, (jnp.zeros((3, 3), v.dtype) if form is None else form(v))

        run = jax.jit(lambda v, body=body: jax.lax.scan(body, v, None, length=steps))
        final, tensors = jax.block_until_ready(run(velocities))
        seconds = best_of(lambda run=run: jax.block_until_ready(run(velocities)), 7)
        last = np.asarray(final, np.float64)  # the velocities the last tensor summed
        exact = last.T @ last
        error = np.max(np.abs(np.asarray(tensors[-1], np.float64) - exact)) / np.max(exact)
        rows.append(
            {
                "N": n,
                "form": name,
                "ms_per_step": 1e3 * seconds / steps,
                "error_u": None if form is None else error / 2**-24,
            }
        )
    return rows


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sizes", type=int, nargs="*", default=[106_480])
    parser.add_argument("--steps", type=int, default=20)
    parser.add_argument("--output", default="kinetic_tensor_forms", help="results file name")
    args = parser.parse_args()
    rows = [row for n in args.sizes for row in measure(n, args.steps)]
    print(f"backend: {jax.default_backend()}")
    print_table(["N", "form", "ms_per_step", "error_u"], rows)
    print(f"wrote {write_json(args.output, {'rows': rows})}")


if __name__ == "__main__":
    main()
