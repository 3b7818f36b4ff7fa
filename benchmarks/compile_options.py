"""XLA:CPU compile options against the default, for the DPD step and the LB update.

Each program is lowered once and compiled with the default options and with each
named variant (`Lowered.compile(options)`: XLA's debug options for that program
alone); the results are compared bit for bit with the default's, then every program
is timed in alternating rounds in one process.  DPD: the driver's compiled chunk of
the float32 Groot–Warren fluid of dpd_throughput.py (particle-steps/s).  LB: the
64³ float32 update of lattice_boltzmann_ab.py (MLUPS).

    python benchmarks/compile_options.py --system dpd --size 3000 [--rounds 5]
    python benchmarks/compile_options.py --system lb [--noise off|uniform]
"""

import argparse
import statistics

import jax
import jax.numpy as jnp
import numpy as np
from _common import alternating_rates
from dpd_throughput import equilibrated_fluid
from lattice_boltzmann_ab import scan_runner

from jaxdpd.run import driver
from jaxdpd.solvents.lattice_boltzmann import fluid

VARIANTS = {
    "xnnpack_off": {"xla_cpu_use_xnnpack": False},
    "onednn": {"xla_cpu_use_onednn": True},
    "fast_runtime": {"xla_cpu_opt_preset": "CPU_OPT_PRESET_FAST_RUNTIME"},
    "tiling_propagation": {"xla_cpu_experimental_enable_tiling_propagation": True},
    "xnn_greedy_graph": {
        "xla_cpu_experimental_xnn_graph_fusion_mode": "XNN_GRAPH_FUSION_MODE_GREEDY"
    },
    # Refused by jaxlib 0.10.2 ("No such compile option"); reported, not timed.
    "thunk_runtime_off": {"xla_cpu_use_thunk_runtime": False},
    "multi_output_fusion": {"xla_cpu_use_multi_output_fusion": True},
}


def dpd_program(size: int, steps: int):
    """(lowered chunk, argument tuple, work per call) of the equilibrated fluid."""
    simulation, state = equilibrated_fluid(size)
    lowered = driver._scan_chunk.lower(simulation.step_fn, state, steps)
    return lowered, (state,), size * steps


def lb_program(noise: str, steps: int, n: int = 64):
    """(lowered scan, argument tuple, lattice updates per call / 1e6) of the LB update."""
    dtype = jnp.dtype("float32")
    kT = 0.0 if noise == "off" else 1e-4
    parameters = fluid.FluidParameters((n, n, n), 1.0, 1.0, 1.0, 0.1, 0.1, kT)
    rng = np.random.default_rng(0)
    impulse = jnp.asarray(1e-3 * rng.standard_normal((3, n, n, n)), dtype)
    start = jnp.asarray(1e-2 * rng.standard_normal((19, n, n, n)), dtype)
    run = scan_runner(fluid, parameters, dtype, noise, impulse, steps)
    return run.lower(start, 0), (start, 0), n**3 * steps / 1e6


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--system", choices=["dpd", "lb"], required=True)
    parser.add_argument("--size", type=int, default=3000, help="DPD particles")
    parser.add_argument("--noise", choices=["off", "uniform"], default="off")
    parser.add_argument("--steps", type=int, default=None)
    parser.add_argument("--rounds", type=int, default=5)
    parser.add_argument("--variants", nargs="+", default=list(VARIANTS), choices=list(VARIANTS))
    args = parser.parse_args()
    if args.system == "dpd":
        lowered, arguments, work = dpd_program(args.size, args.steps or 50)
        unit = "particle-steps/s"
    else:
        lowered, arguments, work = lb_program(args.noise, args.steps or 20)
        unit = "MLUPS"
    programs = {"default": lowered.compile()}
    for name in args.variants:
        try:
            programs[name] = lowered.compile(VARIANTS[name])
        except jax.errors.JaxRuntimeError as error:  # an option XLA does not know
            print(f"{name}: refused ({str(error).splitlines()[0]})")
    reference = jax.tree.leaves(jax.device_get(programs["default"](*arguments)))
    for name, program in programs.items():
        leaves = jax.tree.leaves(jax.device_get(program(*arguments)))
        identical = all(np.array_equal(a, b) for a, b in zip(reference, leaves, strict=True))
        print(f"{name}: bit-identical to the default: {identical}")
    rates = alternating_rates(
        {name: lambda p=program: p(*arguments) for name, program in programs.items()},
        work,
        args.rounds,
    )
    for name, values in rates.items():
        rounds = " ".join(f"{value:.3g}" for value in values)
        print(f"{name}: median {statistics.median(values):.3g} {unit} (rounds: {rounds})")


if __name__ == "__main__":
    main()
