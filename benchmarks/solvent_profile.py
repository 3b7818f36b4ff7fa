"""Where an MPCD or Brownian-dynamics step's time goes: wall time per XLA operation.

MPCD: the scene of benchmarks/mpcd_throughput.py (float32, temperature observed), a
compiled chunk of `--steps` steps.  Brownian dynamics: the run of
benchmarks/brownian_throughput.py (FENE b = 50, shear De = 1, float64).  Times from
benchmarks/thunk_profile.thunk_times, in ms per step; a loop's record includes its
body's operations.  Look the names up in the optimised HLO, which `--hlo PATH` writes.

    python benchmarks/solvent_profile.py mpcd --size 100000
    python benchmarks/solvent_profile.py brownian --size 10000 --noise gaussian
"""

import argparse
from pathlib import Path

import jax
import jax.numpy as jnp
import numpy as np
from thunk_profile import report, thunk_times

import jaxdpd


def mpcd_call(size: int, steps: int):
    """(compiled chunk, its argument) of the MPCD benchmark scene."""
    from mpcd_throughput import solvent_scene

    from jaxdpd.engine.build import build
    from jaxdpd.run import driver

    simulation = build(solvent_scene(size, "float32"))
    state = simulation.init_fn()
    chunk = driver._scan_chunk.lower(simulation.step_fn, state, steps).compile()
    state, _ = chunk(state)
    return chunk, (state,)


def brownian_call(size: int, steps: int, noise: str):
    """(compiled run, its arguments) of the Brownian benchmark."""
    from brownian_throughput import jax_runner

    q0 = jnp.asarray(0.5 * np.random.default_rng(0).standard_normal((size, 3)))
    arguments = (jax.random.key(1), q0)
    return jax_runner(size, steps, noise).lower(*arguments).compile(), arguments


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("method", choices=["mpcd", "brownian"])
    parser.add_argument("--size", type=int, default=100_000)
    parser.add_argument("--steps", type=int, default=None)
    parser.add_argument("--noise", default="gaussian", choices=["gaussian", "three_point"])
    parser.add_argument("--top", type=int, default=15)
    parser.add_argument("--hlo", type=Path, default=None)
    args = parser.parse_args()
    jaxdpd.enable_float64()
    if args.method == "mpcd":
        steps = args.steps or 20
        call, arguments = mpcd_call(args.size, steps)
    else:
        steps = args.steps or 200
        call, arguments = brownian_call(args.size, steps, args.noise)
    jax.block_until_ready(call(*arguments))
    totals = thunk_times(call, *arguments)
    print(f"{args.method}, N = {args.size}:", end=" ")
    report(totals, steps, args.top)
    if args.hlo is not None:
        args.hlo.write_text(call.as_text())


if __name__ == "__main__":
    main()
