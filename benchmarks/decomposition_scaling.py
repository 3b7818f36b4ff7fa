"""Weak and strong scaling of one decomposed DPD system over devices, and what the
exchange between devices costs.

System: Groot–Warren fluid, ρ = 3, a = 25, γ = 4.5, Δt = 0.04, λ = 0.65, float32,
slabs along z.  Strong scaling keeps N fixed (a 20 × 20 × 20 box, N = 24000) and
cuts it into D slabs; weak scaling keeps each device's slab fixed (10 × 10 × 5,
1500 particles) and stacks D of them.  Each (D, N) runs in its own process with D
devices (on CPU `--xla_force_host_platform_device_count=D`; D = 1 is the ordinary
single-device step).  After 200 steps from the random start the buffers are
fitted to the liquid (`simulation.reallocate(state, None)`).  The step time is the
best of several jitted chunks after a warm-up; the exchange time is that of the
same chunk length of an exchange-only program: halo copies out and in
(`exchange.with_halos`) and a migration (`exchange.hand_over`) on the state's rows,
with the same buffer sizes.  Its ratio to the step time is the share of a step the
exchange takes; the halo share is the copies a device steps beside its own
particles.

On a CPU host the forced devices share the machine's cores, so adding devices adds
no arithmetic throughput: the strong-scaling speed-up measures the overheads, not a
parallel gain.  What one device's step moves through memory (XLA's cost analysis
of the compiled step: bytes its operations read and write, per device) is printed
beside the time: the CPU step is bound by memory traffic, and forced devices share
the machine's memory bus.  GPU figures need a multi-GPU machine (docs/scaling_out.md).

`--method lowe_andersen` runs the same tables for a Lowe–Andersen fluid (Γ Δt =
`--collision-probability`, r_T = r_c, no γ), whose sweep exchanges halo velocities
once per round.  `--paired` times instead, for each D > 1, the decomposed step and
the single-device step of the same scene in one process with D devices, alternating
rounds (A, B, A, B, ...; best of each), and reports their ratio: on a loaded machine
a ratio from one process is steadier than two processes' absolute times.

Usage:
    python benchmarks/decomposition_scaling.py [--devices 1 2 4 8] [--steps 50]
        [--method dpd|lowe_andersen] [--collision-probability 1.0]
        [--paired [--lengths 20 20 20]]
Writes benchmarks/results/decomposition_scaling[_<method>][_paired].json.
"""

import argparse
import json
import os
import subprocess
import sys
from pathlib import Path

from _common import best_of, print_table, write_json

STRONG_BOX = (20.0, 20.0, 20.0)
WEAK_SLAB = (10.0, 10.0, 5.0)


DT = 0.04


def scene_dict(lengths, devices: int, method: str = "dpd", probability: float = 1.0) -> dict:
    solvents = {
        "dpd": ({"method": "dpd", "kT": 1.0, "gamma": 4.5}, {"dt": DT, "lambda": 0.65}),
        "lowe_andersen": (
            {"method": "lowe_andersen", "kT": 1.0, "collision_frequency": probability / DT},
            {"dt": DT},
        ),
    }
    solvent, integrator = solvents[method]
    data = {
        "seed": 1,
        "precision": "float32",
        "box": {"lengths": list(lengths)},
        "particles": {"density": 3.0},
        "solvent": solvent,
        "pair": {"a": 25.0},
        "integrator": integrator,
        "output": {"observables": ["temperature"]},
    }
    if devices > 1:
        data["parallel"] = {"devices": devices, "axis": "z"}
    return data


def prepared(lengths, devices: int, method: str, probability: float):
    """(simulation, state) of a configuration after 200 steps, buffers fitted."""
    from jaxdpd.engine.build import build
    from jaxdpd.run import driver
    from jaxdpd.scene import Scene

    simulation = build(Scene.from_dict(scene_dict(lengths, devices, method, probability)))
    state = driver.run(simulation, simulation.init_fn(), 200, 100)  # leave the random start
    return simulation, simulation.reallocate(state, None)  # buffers fitted to the liquid


def paired_worker(lengths, devices: int, steps: int, rounds: int, method, probability) -> dict:
    """The decomposed step against the single-device step of one scene, timed in one
    process in alternating rounds (runs in a process with `devices` devices)."""
    import jax

    from jaxdpd.run import driver

    runs = {d: prepared(lengths, d, method, probability) for d in (1, devices)}

    def chunk(d):
        simulation, state = runs[d]
        return lambda: jax.block_until_ready(driver.run_chunk(simulation, state, steps)[0])

    for d in runs:
        chunk(d)()  # compile
    best = {d: float("inf") for d in runs}
    for _ in range(rounds):
        for d in runs:
            best[d] = min(best[d], best_of(chunk(d), 1))
    return {
        "method": method,
        "devices": devices,
        "N": runs[1][0].scene.n_particles,
        "box": list(lengths),
        "single_ms": 1e3 * best[1] / steps,
        "split_ms": 1e3 * best[devices] / steps,
        "split_vs_single": best[devices] / best[1],
    }


def worker(lengths, devices: int, steps: int, rounds: int, method="dpd", probability=1.0) -> dict:
    """Time one configuration (runs in a process with `devices` devices)."""
    import jax
    import numpy as np
    from jax.sharding import PartitionSpec as P

    from jaxdpd.decomposition import exchange
    from jaxdpd.decomposition.exchange import DOMAINS
    from jaxdpd.run import driver

    simulation, state = prepared(lengths, devices, method, probability)
    chunk = driver.run_chunk(simulation, state, steps)[0]
    jax.block_until_ready(chunk)
    step_time = best_of(
        lambda: jax.block_until_ready(driver.run_chunk(simulation, state, steps)[0]), rounds
    )
    cost = jax.jit(simulation.step_fn).lower(state).compile().cost_analysis()
    cost = cost[0] if isinstance(cost, list) else cost
    row = {
        "devices": devices,
        "N": simulation.scene.n_particles,
        "box": list(lengths),
        "step_ms": 1e3 * step_time / steps,
        "particle_steps_per_s": simulation.scene.n_particles * steps / step_time,
        "device_step_MB": cost["bytes accessed"] / 1e6,
    }
    if devices == 1:
        return row
    layout = simulation.layout
    box = simulation.box
    specs = jax.tree.map(lambda _: P(DOMAINS), state.rows)

    def exchange_only(rows):
        rows = jax.tree.map(lambda leaf: leaf[0], rows)
        k = jax.lax.axis_index(DOMAINS)
        along = box.bind(state.box_state).frame_positions(rows.positions)[:, layout.axis]
        local, *_ = exchange.with_halos(
            rows,
            layout.view_coordinate(along, k),
            layout.width,
            layout.halo,
            state.halo_capacity,
            devices,
        )
        stepped = jax.tree.map(lambda leaf: leaf[: rows.ids.shape[0]], local)
        kept, *_ = exchange.hand_over(
            stepped, layout.owner(along), k, devices, state.migration_capacity
        )
        return jax.tree.map(lambda leaf: leaf[None], kept)

    mapped = jax.shard_map(
        exchange_only, mesh=simulation.mesh, in_specs=(specs,), out_specs=specs, check_vma=False
    )

    @jax.jit
    def exchanges(rows):
        return jax.lax.fori_loop(0, steps, lambda _, r: mapped(r), rows)

    jax.block_until_ready(exchanges(state.rows))
    exchange_time = best_of(lambda: jax.block_until_ready(exchanges(state.rows)), rounds)
    owned = float(np.mean(np.sum(np.asarray(state.rows.ids) >= 0, axis=1)))
    row.update(
        exchange_ms=1e3 * exchange_time / steps,
        exchange_share=exchange_time / step_time,
        halo_share=float(np.max(np.asarray(chunk.needs.halo))) * 2 / owned,
    )
    return row


def run_worker(lengths, devices: int, *options, paired=False) -> dict:
    environment = {
        **os.environ,
        "XLA_FLAGS": f"--xla_force_host_platform_device_count={devices}",
        "PYTHONPATH": str(Path(__file__).resolve().parents[1]),
    }
    flag = "--paired-worker" if paired else "--worker"
    command = [sys.executable, __file__, flag, json.dumps([lengths, devices, *options])]
    completed = subprocess.run(command, capture_output=True, text=True, env=environment)
    if completed.returncode:
        raise RuntimeError(completed.stderr[-2000:])
    return json.loads(completed.stdout.splitlines()[-1])


def main() -> None:
    parser = argparse.ArgumentParser()
    parser.add_argument("--devices", type=int, nargs="+", default=[1, 2, 4, 8])
    parser.add_argument("--steps", type=int, default=50)
    parser.add_argument("--rounds", type=int, default=3)
    parser.add_argument("--method", choices=("dpd", "lowe_andersen"), default="dpd")
    parser.add_argument("--collision-probability", type=float, default=1.0)
    parser.add_argument("--paired", action="store_true")
    parser.add_argument("--lengths", type=float, nargs=3, default=STRONG_BOX)
    parser.add_argument("--worker", help=argparse.SUPPRESS)
    parser.add_argument("--paired-worker", help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.worker:
        print(json.dumps(worker(*json.loads(args.worker))))
        return
    if args.paired_worker:
        print(json.dumps(paired_worker(*json.loads(args.paired_worker))))
        return
    options = (args.steps, args.rounds, args.method, args.collision_probability)
    name = "decomposition_scaling" + ("" if args.method == "dpd" else f"_{args.method}")
    if args.paired:
        rows = []
        for devices in (d for d in args.devices if d > 1):
            rows.append(run_worker(list(args.lengths), devices, *options, paired=True))
            print(json.dumps(rows[-1]), flush=True)
        print_table(["method", "devices", "N", "single_ms", "split_ms", "split_vs_single"], rows)
        write_json(name + "_paired", {"rows": rows, "steps": args.steps})
        return
    rows = []
    for kind in ("strong", "weak"):
        for devices in args.devices:
            if kind == "strong":
                lengths = STRONG_BOX
            else:
                lengths = (WEAK_SLAB[0], WEAK_SLAB[1], WEAK_SLAB[2] * devices)
            row = run_worker(lengths, devices, *options)
            row["scaling"] = kind
            rows.append(row)
            print(json.dumps(row), flush=True)
    for kind in ("strong", "weak"):
        base = next(r for r in rows if r["scaling"] == kind and r["devices"] == 1)
        for row in rows:
            if row["scaling"] == kind:
                row["time_vs_1"] = row["step_ms"] / base["step_ms"]
                row["traffic_vs_1"] = row["device_step_MB"] / base["device_step_MB"]
    columns = [
        "scaling",
        "devices",
        "N",
        "step_ms",
        "time_vs_1",
        "particle_steps_per_s",
        "device_step_MB",
        "traffic_vs_1",
        "exchange_ms",
        "exchange_share",
        "halo_share",
    ]
    print_table(columns, rows)
    write_json(name, {"rows": rows, "steps": args.steps})


if __name__ == "__main__":
    main()
