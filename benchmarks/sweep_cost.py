"""Cost of a B-replica shear-rate sweep (jaxdpd.run.ensemble) against B single runs.

The same scene (a sheared Groot–Warren DPD fluid: ρ = 3, a = 25, γ = 4.5, Δt = 0.04,
λ = 0.65, float32, Lees–Edwards box) is run two ways for B ∈ {1, 4, 16} replicas,
each replica with its own shear rate and seed:

- singles: B runs one after the other with jaxdpd.run.driver (one compiled chunk shared
  by all of them);
- sweep: one vmapped batch of B replicas with jaxdpd.run.ensemble (one compiled chunk
  per B, since the batch shape is static).

Compilation is timed separately: the first chunk of each program is run once before
timing (its wall time minus a compiled chunk's is reported: compile_single_s once,
since every single run shares one program, and compile_sweep_s per B).  The ratio
singles_s / sweep_s > 1 means the sweep is cheaper than the loop.  All timings come
from the same run, so the ratio is meaningful on a shared, loaded machine even when
the absolute seconds are not.

Usage:
    python benchmarks/sweep_cost.py [--particles 1000] [--steps 400] [--chunk 100]
        [--replicas 1 4 16]
Writes benchmarks/results/sweep_cost.json.
"""

import argparse

import jax
import numpy as np
from _common import peak_rss_mib, print_table, timed, write_json

from jaxdpd.engine.build import build
from jaxdpd.run import driver, ensemble
from jaxdpd.scene import Scene


def sheared_fluid(particles: int) -> Scene:
    return Scene.from_dict(
        {
            "seed": 3,
            "precision": "float32",
            "particles": {"density": 3.0, "count": particles},
            "solvent": {"method": "dpd", "kT": 1.0, "gamma": 4.5},
            "pair": {"a": 25.0},
            "integrator": {"dt": 0.04, "lambda": 0.65},
            "flow": {"kind": "shear", "shear_rate": 0.1},
            "output": {"observables": ["temperature", "pressure"]},
        }
    )


def measure(simulation, start, replicas: int, steps: int, chunk: int) -> dict:
    rates = np.linspace(0.05, 0.5, replicas)
    seeds = [100 + k for k in range(replicas)]
    batch = ensemble.replicate(simulation, start, seeds=seeds, shear_rates=rates)
    singles = ensemble.unstack(batch)
    # In a trial the first driver run of a replica taken out of the batch took a
    # compilation's time (same tree, dtypes and sharding as the state the single
    # program was compiled for; cause not found): run one chunk of it, untimed.
    timed(driver.run, simulation, singles[0], chunk, chunk)
    # Compilation of this batch shape: its first chunk minus a compiled chunk.
    _, first_sweep = timed(driver.run, simulation, batch, chunk, chunk)
    _, again_sweep = timed(driver.run, simulation, batch, chunk, chunk)
    singles_seconds = 0.0
    for state in singles:
        _, seconds = timed(driver.run, simulation, state, steps, chunk)
        singles_seconds += seconds
    _, sweep_seconds = timed(driver.run, simulation, batch, steps, chunk)
    particle_steps = replicas * simulation.scene.n_particles * steps
    return {
        "B": replicas,
        "N": simulation.scene.n_particles,
        "steps": steps,
        "singles_s": singles_seconds,
        "sweep_s": sweep_seconds,
        "ratio_singles_over_sweep": singles_seconds / sweep_seconds,
        "singles_particle_steps_per_s": particle_steps / singles_seconds,
        "sweep_particle_steps_per_s": particle_steps / sweep_seconds,
        "compile_sweep_s": first_sweep - again_sweep,
        "peak_rss_mib": peak_rss_mib(),
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--particles", type=int, default=1000)
    parser.add_argument("--steps", type=int, default=400)
    parser.add_argument("--chunk", type=int, default=100)
    parser.add_argument("--replicas", type=int, nargs="+", default=[1, 4, 16])
    args = parser.parse_args()
    simulation = build(sheared_fluid(args.particles))
    # The single-run program is compiled once for every B: its first chunk minus a
    # compiled chunk.
    state, first_single = timed(
        driver.run, simulation, simulation.init_fn(), args.chunk, args.chunk
    )
    start, again_single = timed(driver.run, simulation, state, args.chunk, args.chunk)
    compile_single = first_single - again_single
    print(f"single-run compilation: {compile_single:.1f} s")
    rows = []
    for replicas in args.replicas:
        rows.append(measure(simulation, start, replicas, args.steps, args.chunk))
        print_table(list(rows[-1]), rows[-1:])
    print()
    print_table(list(rows[0]), rows)
    path = write_json(
        "sweep_cost",
        {
            "scene": simulation.scene.to_dict(),
            "devices": [str(device) for device in jax.devices()],
            "compile_single_s": compile_single,
            "rows": rows,
        },
    )
    print(f"wrote {path}")


if __name__ == "__main__":
    main()
