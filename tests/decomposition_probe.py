"""Run one scene on one device and decomposed over D devices; print the comparison as JSON.

Run in a fresh process (the device count of JAX's CPU backend is fixed when JAX
starts), e.g. by tests/test_decomposition.py:

    python tests/decomposition_probe.py --devices 4 --case shear --steps 20
"""

import argparse
import json
import os
import sys


def scenes(case: str, length_y: float = 10.0) -> dict:
    """The single-device scene of a case (float64, seed 3, ρ = 3, 6 × L_y × 6)."""
    chains = {
        "particles": {
            "density": 3.0,
            "species": [{"name": "bead", "fraction": 0.2}, {"name": "solvent", "fraction": 0.8}],
        },
        "polymers": [
            {
                "species": "bead",
                "beads": 8,
                "bond": {"law": "fene", "spring_constant": 10.0, "max_extension": 1.5},
            }
        ],
    }
    # Γ Δt = 1: every pair within r_c is thermalised, the longest sweeps.
    lowe_andersen = {"method": "lowe_andersen", "kT": 1.0, "collision_frequency": 25.0}
    scene = {
        "seed": 3,
        "precision": "float64",
        "box": {"lengths": [6.0, length_y, 6.0]},
        "particles": {"density": 3.0},
        "solvent": {"method": "dpd", "kT": 1.0, "gamma": 4.5},
        "pair": {"a": 25.0},
        "integrator": {"dt": 0.04, "lambda": 0.65},
        "output": {"observables": ["temperature", "pressure"]},
    }
    cases = {
        "fluid": {},
        "chains": chains,
        "shear": {**chains, "flow": {"kind": "shear", "shear_rate": 0.5}},
        "elongation": {"flow": {"kind": "planar_elongation", "elongation_rate": 0.2}},
        "oscillatory": {
            **chains,
            "flow": {"kind": "shear", "shear_rate": 0.5, "oscillation_frequency": 0.5},
        },
        "hoogerbrugge_koelman": {"solvent": {"method": "hoogerbrugge_koelman"}},
        "hoogerbrugge_koelman_shear": {
            "solvent": {"method": "hoogerbrugge_koelman"},
            "flow": {"kind": "shear", "shear_rate": 0.05},
        },
        "lowe_andersen": {**chains, "solvent": lowe_andersen, "integrator": {"dt": 0.04}},
        "lowe_andersen_shear": {
            **chains,
            "solvent": lowe_andersen,
            "integrator": {"dt": 0.04},
            "flow": {"kind": "shear", "shear_rate": 0.5},
        },
        "lowe_andersen_elongation": {
            **chains,
            "solvent": lowe_andersen,
            "integrator": {"dt": 0.04},
            "flow": {"kind": "planar_elongation", "elongation_rate": 0.2},
        },
        # No conservative force: every force is exactly zero on one device and on
        # several, so the two runs differ only if the sweeps do.
        "lowe_andersen_ideal_gas": {
            "solvent": lowe_andersen,
            "pair": {"a": 0.0},
            "integrator": {"dt": 0.04},
        },
    }
    scene.update(cases[case])
    if scene["solvent"]["method"] == "hoogerbrugge_koelman":
        del scene["pair"], scene["integrator"]
    return scene


def main() -> None:
    parser = argparse.ArgumentParser()
    parser.add_argument("--devices", type=int, required=True)
    parser.add_argument("--case", required=True)
    parser.add_argument("--steps", type=int, default=20)
    parser.add_argument("--length-y", type=float, default=10.0)
    parser.add_argument("--equilibration", type=int, default=0)
    args = parser.parse_args()
    os.environ["XLA_FLAGS"] = f"--xla_force_host_platform_device_count={args.devices}"
    import numpy as np

    from jaxdpd.analysis.statistics import block_average
    from jaxdpd.engine.build import build
    from jaxdpd.run import driver
    from jaxdpd.scene import Scene

    data = scenes(args.case, args.length_y)
    single = build(Scene.from_dict(data))
    split = build(Scene.from_dict({**data, "parallel": {"devices": args.devices}}))
    samples = {}

    def keep(name):
        def on_chunk(result):
            samples[name] = result.series

        return on_chunk

    reference, state = single.init_fn(), split.init_fn()
    if args.equilibration:
        reference = driver.run(single, reference, args.equilibration, args.equilibration)
        state = driver.run(split, state, args.equilibration, args.equilibration)
    reference = driver.run(single, reference, args.steps, args.steps, keep("single"))
    state = driver.run(split, state, args.steps, args.steps, keep("split"))
    particles = state.particles()
    owner = np.full(split.scene.n_particles, -1)
    for device, ids in enumerate(np.asarray(state.rows.ids)):
        owner[ids[ids >= 0]] = device
    crossing = 0
    for block in split.blocks:
        lower = np.arange(block.first, block.stop - 1)
        lower = lower[(lower - block.first) % block.beads != block.beads - 1]
        crossing += int(np.sum(owner[lower] != owner[lower + 1]))
    result = {
        "difference": {
            name: float(np.max(np.abs(particles[name] - np.asarray(getattr(reference, name)))))
            for name in ("positions", "velocities")
        },
        "momentum": float(np.max(np.abs(particles["velocities"].sum(axis=0)))),
        "single_momentum": float(np.max(np.abs(np.asarray(reference.velocities).sum(axis=0)))),
        "pressure_difference": float(
            np.max(np.abs(samples["split"]["pressure"] - samples["single"]["pressure"]))
        ),
        "temperature_difference": float(
            np.max(np.abs(samples["split"]["temperature"] - samples["single"]["temperature"]))
        ),
        "block_averages": {
            run: {
                name: [float(v) for v in block_average(np.asarray(series[name]))]
                for name in ("temperature", "pressure")
            }
            for run, series in samples.items()
        },
        "bonds_across_slabs": crossing,
        "particles_per_device": [int(n) for n in (np.asarray(state.rows.ids) >= 0).sum(axis=1)],
        "flags": int(state.flags),
    }
    json.dump(result, sys.stdout)


if __name__ == "__main__":
    main()
