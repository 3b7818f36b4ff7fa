"""Record every observable of one scene on one device and decomposed over D devices;
print the comparison as JSON.

Run in a fresh process (the device count of JAX's CPU backend is fixed when JAX
starts), e.g. by tests/test_decomposition_observables.py:

    python tests/decomposition_observables_probe.py --devices 4 --case shear
"""

import argparse
import json
import os
import sys

from decomposition_probe import scenes

# A chain solution (20 % beads in chains of 8 beads) in a cubic box by default, so
# that every observable that decomposes applies.
ALL_OBSERVABLES = [
    "temperature",
    "pressure",
    "conformation",
    "profile",
    "rdf",
    "transverse_current",
]
FLOWS = {
    "rest": None,
    "shear": {"kind": "shear", "shear_rate": 0.5},
    "elongation": {"kind": "planar_elongation", "elongation_rate": 0.2},
}


def scene(case: str, lengths: list, steps: int, observables: list, bond: dict) -> dict:
    """The single-device scene of a case: tests/decomposition_probe.py's chain
    solution (float64, seed 3, ρ = 3, 20 % beads in chains of 8) with `bond`."""
    data = scenes("chains")
    data["box"] = {"lengths": lengths}
    data["polymers"][0]["bond"] = bond
    data["run"] = {"steps": steps, "chunk": steps // 2, "equilibration": 0}
    data["output"] = {"observables": observables, "rdf_max": 2.0, "profile_bins": 8}
    if FLOWS[case] is not None:
        data["flow"] = FLOWS[case]
    return data


def chains_across_devices(state, blocks):
    """(springs whose beads two devices own, chains whose beads several devices own)."""
    import numpy as np

    ids = np.asarray(state.rows.ids)
    owner = np.full(ids.max() + 1, -1)
    for device, rows in enumerate(ids):
        owner[rows[rows >= 0]] = device
    springs = chains = 0
    for block in blocks:
        owners = block.take(owner)  # (C, M)
        springs += int(np.sum(owners[:, 1:] != owners[:, :-1]))
        chains += int(np.sum(np.any(owners != owners[:, :1], axis=1)))
    return springs, chains


def main() -> None:
    parser = argparse.ArgumentParser()
    parser.add_argument("--devices", type=int, required=True)
    parser.add_argument("--case", choices=sorted(FLOWS), required=True)
    parser.add_argument("--lengths", type=float, nargs=3, default=[7.2, 7.2, 7.2])
    parser.add_argument("--steps", type=int, default=20)
    parser.add_argument("--observables", nargs="+", default=ALL_OBSERVABLES)
    parser.add_argument(
        "--max-extension", type=float, default=0.0, help="FENE Q0; 0: Hookean springs"
    )
    args = parser.parse_args()
    os.environ["XLA_FLAGS"] = f"--xla_force_host_platform_device_count={args.devices}"
    import numpy as np

    from jaxdpd.engine.build import build
    from jaxdpd.observables import OBSERVABLES
    from jaxdpd.run import driver
    from jaxdpd.scene import Scene

    bond = {"law": "fene", "spring_constant": 10.0, "max_extension": args.max_extension}
    if not args.max_extension:
        bond = {"law": "hookean", "spring_constant": 10.0}
    data = scene(args.case, args.lengths, args.steps, args.observables, bond)
    simulations = {
        "single": build(Scene.from_dict(data)),
        "split": build(Scene.from_dict({**data, "parallel": {"devices": args.devices}})),
    }
    series, states, rdf = {}, {}, {}
    for name, simulation in simulations.items():
        chunks = []
        # g(r) as the runner samples it: the chunk accumulator at every chunk end.
        accumulator = OBSERVABLES.get("rdf").chunk_accumulator(simulation)

        def on_chunk(result, chunks=chunks, accumulator=accumulator):
            chunks.append(result.series)
            if "rdf" in args.observables:
                accumulator.observe(result.state)

        chunk = simulation.scene.run.chunk
        states[name] = driver.run(simulation, simulation.init_fn(), args.steps, chunk, on_chunk)
        series[name] = {key: np.concatenate([c[key] for c in chunks]) for key in chunks[0]}
        rdf[name] = accumulator.result()
    differences, non_finite = {}, {}
    for key, single in series["single"].items():
        split = series["split"].get(key)
        if split is None:
            differences[key] = None
            continue
        non_finite[key] = int(np.sum(~np.isfinite(split)) + np.sum(~np.isfinite(single)))
        differences[key] = float(np.max(np.abs(split - single)))
    result = {
        "differences": differences,
        "non_finite": non_finite,
        "split_only": sorted(set(series["split"]) - set(series["single"])),
        "flags": int(states["split"].flags),
    }
    if "rdf" in args.observables:
        (_, single), (_, split) = rdf["single"], rdf["split"]
        counted = np.isfinite(single)
        result["rdf_difference"] = float(np.max(np.abs(split[counted] - single[counted])))
        result["rdf_peak"] = float(np.max(single[counted]))
    result["springs_across_slabs"], result["chains_across_slabs"] = chains_across_devices(
        states["split"], simulations["split"].blocks
    )
    json.dump(result, sys.stdout)


if __name__ == "__main__":
    main()
