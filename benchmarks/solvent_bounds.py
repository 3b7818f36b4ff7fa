"""MPCD and Brownian dynamics against their bounds, measured in one process.

For each method the bytes and the operations of one update (a particle-collision, a
dumbbell-step) are counted two ways:

* minimal: the update must read and write its particle's state once (MPCD: position
  and velocity, 12 values; BD: the connector, 6 values);
* as written: XLA's cost analysis of the compiled step (`compiled.cost_analysis()`):
  bytes moved between its fused operations, flops (every elementwise operation,
  integer hashing and divisions included, counts one) and transcendentals.

The machine is measured in the same run: the copy bandwidth B of the state's arrays
(benchmarks/_common.copy_bandwidth), a flop rate F (jitted multiply-adds, 2 flops each,
8 independent chains of 8 per element over 64 Ki values on a CPU, in cache, both cores;
4 Mi on a GPU) and a transcendental rate T (the same with square roots). Memory time =
bytes / B; compute time = flops / F + transcendentals / T. It is optimistic: a division
or an integer operation counts as one flop, every transcendental (a logarithm, an
arccosine) as a square root. The binding bound is the update rate at the larger of the
two times; the fraction is the measured rate over it (`fraction`: memory time from the
minimal bytes; `fraction_xla_bytes`: from XLA's bytes). The machine is shared: figures
vary 2-4x with load; ratios within one run are what count.

Usage:
    python benchmarks/solvent_bounds.py [--mpcd-sizes 100000] [--bd-sizes 10000]
        [--output solvent_bounds]
Writes benchmarks/results/<output>.json.
"""

import argparse

import jax
import jax.numpy as jnp
import numpy as np
from _common import best_of, copy_bandwidth, print_table, write_json

import jaxdpd

CHAINS, LINKS, REPEATS = 8, 8, 50
# Chunks timed per method; the rate is the best.  Chunks run right after another
# program's run slower (an MPCD chunk after a C one by up to 1.7x,
# docs/performance_solvents.md): ten give a quiet chunk more chances than three.
RATE_REPEATS = 10


def rate_size() -> int:
    """Values per pass of the rate measurements: 64 Ki stay in a CPU core's cache; a
    GPU needs about 4 Mi (16 MB in float32, inside an H100's 50 MB L2) to keep all its
    units busy, where 64 Ki would time kernel launches instead of arithmetic."""
    return 2**16 if jax.default_backend() == "cpu" else 2**22


def _chain_rate(dtype, link, ops_per_link: int) -> float:
    """Operations/s of `link` applied LINKS times to CHAINS independent values per
    element (independent chains hide the operation's latency), REPEATS times."""
    x = jnp.linspace(0.5, 1.5, rate_size(), dtype=dtype)

    def body(value, _):
        chains = [value + jnp.asarray(0.01 * c, dtype) for c in range(CHAINS)]
        for _ in range(LINKS):
            chains = [link(chain) for chain in chains]
        return sum(chains[1:], chains[0]) * jnp.asarray(1 / CHAINS, dtype), None

    run = jax.jit(lambda v: jax.lax.scan(body, v, None, length=REPEATS)[0])
    run(x).block_until_ready()
    seconds = best_of(lambda: run(x).block_until_ready(), 5)
    return ops_per_link * CHAINS * LINKS * x.size * REPEATS / seconds


def flop_rate(dtype) -> float:
    """Flops/s of fused multiply-adds (2 flops each)."""
    a, b = jnp.asarray(0.999, dtype), jnp.asarray(1e-3, dtype)
    return _chain_rate(dtype, lambda v: v * a + b, 2)


def transcendental_rate(dtype) -> float:
    """Square roots/s (with one add each, not counted)."""
    b = jnp.asarray(0.25, dtype)
    return _chain_rate(dtype, lambda v: jnp.sqrt(v + b), 1)


def cost_per_update(compiled, updates: int) -> dict:
    """XLA's count of bytes, flops and transcendentals of one call, per update."""
    cost = compiled.cost_analysis()
    cost = cost[0] if isinstance(cost, list) else cost
    keys = {"bytes accessed": "bytes", "flops": "flops", "transcendentals": "transcendentals"}
    return {short: cost.get(key, 0.0) / updates for key, short in keys.items()}


def bound_row(method, n, precision, rate, minimal_bytes, cost, machine) -> dict:
    """The table row: times per update, bounds and fractions."""
    memory = minimal_bytes / machine["bandwidth"]
    written_memory = cost["bytes"] / machine["bandwidth"]
    compute = cost["flops"] / machine["flops"] + cost["transcendentals"] / machine["sqrt"]
    binding = max(memory, compute)
    return {
        "method": method,
        "N": n,
        "precision": precision,
        "rate_per_s": rate,
        "min_bytes": minimal_bytes,
        "xla_bytes": cost["bytes"],
        "xla_flops": cost["flops"],
        "xla_transc": cost["transcendentals"],
        "memory_bound": 1 / memory,
        "xla_memory_bound": 1 / written_memory,
        "compute_bound": 1 / compute,
        "binding": "memory" if memory >= compute else "compute",
        "bound_per_s": 1 / binding,
        "fraction": rate / (1 / binding),
        "fraction_xla_bytes": rate / (1 / max(written_memory, compute)),
    }


def machine_rates(dtype) -> dict:
    """Flop and square-root rates of this machine (best of 3 chains each)."""
    return {"flops": flop_rate(dtype), "sqrt": transcendental_rate(dtype)}


def measure_mpcd(n: int, observed: bool, rates: dict, steps: int = 20) -> dict:
    from mpcd_throughput import solvent_scene

    from jaxdpd.engine.build import build
    from jaxdpd.run import driver

    scene = solvent_scene(n, "float32")
    if not observed:
        scene = scene.replace(output={"observables": []})
    simulation = build(scene)
    state = simulation.init_fn()
    chunk = driver._scan_chunk.lower(simulation.step_fn, state, steps).compile()
    state, _ = chunk(state)
    seconds = best_of(lambda: jax.block_until_ready(chunk(state)), RATE_REPEATS)
    count = scene.n_particles
    cost = cost_per_update(jax.jit(simulation.step_fn).lower(state).compile(), count)
    machine = {"bandwidth": copy_bandwidth((count, 6), jnp.float32, steps), **rates}
    method = "mpcd, temperature" if observed else "mpcd, no observable"
    row = bound_row(method, count, "float32", count * steps / seconds, 48, cost, machine)
    return row | {f"machine_{k}": v for k, v in machine.items()}


def measure_brownian(n: int, noise: str, rates: dict, steps: int = 200) -> dict:
    from brownian_throughput import DE, DT, B, jax_runner

    from jaxdpd.brownian import FENE, state_from_connectors, velocity_gradient
    from jaxdpd.brownian.dynamics import _advance, cast_params

    q0 = jnp.asarray(0.5 * np.random.default_rng(0).standard_normal((n, 3)))
    run, key = jax_runner(n, steps, noise), jax.random.key(1)
    jax.block_until_ready(run(key, q0))
    seconds = best_of(lambda: jax.block_until_ready(run(key, q0)), RATE_REPEATS)
    spring = FENE(B)
    kappa, dt, spring = cast_params(jnp.float64, velocity_gradient("shear", DE), DT, spring)
    state = state_from_connectors(q0, spring)
    step = jax.jit(lambda k, s: _advance(k, s, kappa, spring, dt, noise))
    cost = cost_per_update(step.lower(key, state).compile(), n)
    machine = {"bandwidth": copy_bandwidth((n, 3), jnp.float64, steps), **rates}
    row = bound_row(f"bd {noise}", n, "float64", n * steps / seconds, 48, cost, machine)
    return row | {f"machine_{k}": v for k, v in machine.items()}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--mpcd-sizes", type=int, nargs="*", default=[100_000])
    parser.add_argument("--bd-sizes", type=int, nargs="*", default=[10_000])
    parser.add_argument("--output", default="solvent_bounds", help="results file name")
    args = parser.parse_args()
    jaxdpd.enable_float64()
    rates32, rates64 = machine_rates(jnp.float32), machine_rates(jnp.float64)
    rows = [
        measure_mpcd(n, observed, rates32) for n in args.mpcd_sizes for observed in (True, False)
    ]
    noises = ("gaussian", "three_point")
    rows += [measure_brownian(n, noise, rates64) for n in args.bd_sizes for noise in noises]
    print_table(
        ["method", "N", "rate_per_s", "min_bytes", "xla_bytes", "xla_flops", "xla_transc",
         "memory_bound", "compute_bound", "binding", "fraction", "fraction_xla_bytes"],
        rows,
    )  # fmt: skip
    print_table(["method", "N", "machine_bandwidth", "machine_flops", "machine_sqrt"], rows)
    print(f"wrote {write_json(args.output, {'rows': rows})}")


if __name__ == "__main__":
    main()
