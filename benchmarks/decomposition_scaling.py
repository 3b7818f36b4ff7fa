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

Usage:
    python benchmarks/decomposition_scaling.py [--devices 1 2 4 8] [--steps 50]
Writes benchmarks/results/decomposition_scaling.json.
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


def scene_dict(lengths, devices: int) -> dict:
    data = {
        "seed": 1,
        "precision": "float32",
        "box": {"lengths": list(lengths)},
        "particles": {"density": 3.0},
        "solvent": {"method": "dpd", "kT": 1.0, "gamma": 4.5},
        "pair": {"a": 25.0},
        "integrator": {"dt": 0.04, "lambda": 0.65},
        "output": {"observables": ["temperature"]},
    }
    if devices > 1:
        data["parallel"] = {"devices": devices, "axis": "z"}
    return data


def worker(lengths, devices: int, steps: int, rounds: int) -> dict:
    """Time one configuration (runs in a process with `devices` devices)."""
    import jax
    import numpy as np
    from jax.sharding import PartitionSpec as P

    from jaxdpd.decomposition import exchange
    from jaxdpd.decomposition.exchange import DOMAINS
    from jaxdpd.engine.build import build
    from jaxdpd.run import driver
    from jaxdpd.scene import Scene

    simulation = build(Scene.from_dict(scene_dict(lengths, devices)))
    state = driver.run(simulation, simulation.init_fn(), 200, 100)  # leave the random start
    state = simulation.reallocate(state, None)  # buffers fitted to the liquid
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
        local, _ = exchange.with_halos(
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


def run_worker(lengths, devices: int, steps: int, rounds: int) -> dict:
    environment = {
        **os.environ,
        "XLA_FLAGS": f"--xla_force_host_platform_device_count={devices}",
        "PYTHONPATH": str(Path(__file__).resolve().parents[1]),
    }
    command = [sys.executable, __file__, "--worker", json.dumps([lengths, devices, steps, rounds])]
    completed = subprocess.run(command, capture_output=True, text=True, env=environment)
    if completed.returncode:
        raise RuntimeError(completed.stderr[-2000:])
    return json.loads(completed.stdout.splitlines()[-1])


def main() -> None:
    parser = argparse.ArgumentParser()
    parser.add_argument("--devices", type=int, nargs="+", default=[1, 2, 4, 8])
    parser.add_argument("--steps", type=int, default=50)
    parser.add_argument("--rounds", type=int, default=3)
    parser.add_argument("--worker", help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.worker:
        print(json.dumps(worker(*json.loads(args.worker))))
        return
    rows = []
    for kind in ("strong", "weak"):
        for devices in args.devices:
            if kind == "strong":
                lengths = STRONG_BOX
            else:
                lengths = (WEAK_SLAB[0], WEAK_SLAB[1], WEAK_SLAB[2] * devices)
            row = run_worker(lengths, devices, args.steps, args.rounds)
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
    write_json("decomposition_scaling", {"rows": rows, "steps": args.steps})


if __name__ == "__main__":
    main()
