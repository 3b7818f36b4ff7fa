"""Golden trajectories: record, or check that the engine still reproduces them bit for bit.

Each scene (the packaged ones and one per solvent × flow combination the tests use,
all in float64) runs a fixed number of steps from its own initial state; the final
positions, velocities, forces, image counters and every per-step sample are stored
in `tests/golden/<name>.npz`.  A refactor that keeps the physics must reproduce them
exactly on the same machine (`--check`); across machines XLA may round differently,
which is why the test in tests/test_golden_trajectories.py allows float64 round-off.

    python tests/golden/record.py            # (re-)record every scene
    python tests/golden/record.py --check    # compare, report max |difference|
"""

import argparse
import copy
import json
import pathlib
import sys
import tomllib

import numpy as np

HERE = pathlib.Path(__file__).parent
STEPS = 40

DUMBBELLS = {
    "seed": 11,
    "precision": "float64",
    "particles": {
        "density": 3.0,
        "count": 600,
        "species": [
            {"name": "dumbbell", "fraction": 0.2},
            {"name": "solvent", "fraction": 0.8},
        ],
    },
    "solvent": {"method": "dpd", "kT": 1.0, "gamma": 4.5},
    "pair": {"kind": "soft_repulsion", "a": 25.0},
    "polymers": [
        {
            "species": "dumbbell",
            "beads": 2,
            "bond": {"law": "fene", "spring_constant": 3.125, "max_extension": 4.0},
        }
    ],
    "integrator": {"dt": 0.04, "lambda": 0.65},
    "output": {"observables": ["temperature", "pressure", "conformation", "profile"]},
}
CHAINS = {
    **DUMBBELLS,
    "polymers": [
        {"species": "dumbbell", "beads": 6, "bond": {"law": "hookean", "spring_constant": 4.0}}
    ],
}
SHEAR = {"kind": "shear", "shear_rate": 0.3}
OSCILLATION = {"kind": "shear", "shear_rate": 0.3, "oscillation_frequency": 0.5}
ELONGATION = {"kind": "planar_elongation", "elongation_rate": 0.2}
KR_BOX = {"lengths": [7.0, 5.0, 7.0]}
LOWE_ANDERSEN = {"method": "lowe_andersen", "kT": 1.0, "collision_frequency": 2.0}
MPCD = {
    "seed": 3,
    "precision": "float64",
    "box": {"lengths": [6.0, 6.0, 6.0]},
    "particles": {
        "count": 1080,
        "species": [
            {"name": "solvent", "count": 1000},
            {"name": "monomer", "count": 80, "mass": 5.0},
        ],
    },
    "solvent": {"method": "mpcd", "collision_time": 0.1, "kT": 1.0},
    "integrator": {"dt": 0.01},
    "polymers": [
        {"species": "monomer", "beads": 10, "bond": {"law": "hookean", "spring_constant": 3.0}}
    ],
    "output": {"observables": ["temperature", "pressure", "conformation"]},
}
HOOGERBRUGGE_KOELMAN = {
    "seed": 7,
    "precision": "float64",
    "particles": {
        "density": 3.0,
        "count": 600,
        "species": [{"name": "bead", "fraction": 0.2}, {"name": "solvent", "fraction": 0.8}],
    },
    "solvent": {"method": "hoogerbrugge_koelman", "pi0": 0.05, "omega": 0.5, "delta_pi": 0.05},
    "polymers": [
        {"species": "bead", "beads": 4, "bond": {"law": "hookean", "spring_constant": 10.0}}
    ],
    "output": {"observables": ["temperature", "pressure", "conformation"]},
}


def _with(base: dict, **sections) -> dict:
    data = copy.deepcopy(base)
    data.update(copy.deepcopy(sections))
    return data


# The flowing HK scenes: the default fluid (k_BT ≈ 0.0016) with Schlijper et al.'s
# weak springs, stable at δt = 1 (the springs of HOOGERBRUGGE_KOELMAN, K = 10, are
# not: that trajectory runs away within ten steps), at rates of its thermal speed.
HK_FLUID = _with(
    HOOGERBRUGGE_KOELMAN,
    solvent={"method": "hoogerbrugge_koelman"},
    polymers=[
        {"species": "bead", "beads": 4, "bond": {"law": "hookean", "spring_constant": 0.006}}
    ],
)
HK_SHEAR = {"kind": "shear", "shear_rate": 0.02}


def _packaged(name: str) -> dict:
    text = (HERE.parent.parent / "jaxdpd" / "scenes" / f"{name}.toml").read_text()
    data = tomllib.loads(text)
    data["precision"] = "float64"
    return data


DPD_SAMPLERS = ["temperature", "pressure", "conformation", "profile", "dynamics", "rdf"]

SCENES = {
    "demo": _packaged("demo"),
    "lb_chain": _packaged("lb_chain"),
    "dpd_rest": _with(
        DUMBBELLS,
        output={
            "observables": DPD_SAMPLERS + ["transverse_current"],
            "correlator_every": 2,
            "rdf_max": 2.5,
        },
    ),
    "dpd_shear": _with(CHAINS, flow=SHEAR),
    "dpd_oscillatory_shear": _with(CHAINS, flow=OSCILLATION),
    "dpd_elongation": _with(
        {k: v for k, v in CHAINS.items() if k != "particles"},
        box=KR_BOX,
        particles={"density": 3.0, "species": DUMBBELLS["particles"]["species"]},
        flow=ELONGATION,
    ),
    "dpd_gaussian_noise_masses": _with(
        DUMBBELLS,
        solvent={"method": "dpd", "kT": 1.0, "gamma": 4.5, "noise": "gaussian"},
        particles={
            "density": 3.0,
            "count": 600,
            "species": [
                {"name": "dumbbell", "fraction": 0.2, "mass": 2.0},
                {"name": "solvent", "fraction": 0.8},
            ],
        },
    ),
    "dpd_tagged_drag": _with(
        {k: v for k, v in DUMBBELLS.items() if k != "polymers"},
        body_force={"kind": "tagged", "amplitude": 0.5, "species": "dumbbell"},
        output={"observables": ["temperature", "pressure", "drag"]},
    ),
    "dpd_cosine_force": _with(
        DUMBBELLS,
        body_force={"kind": "cosine", "amplitude": 0.2, "waves": 1},
        output={"observables": ["temperature", "profile"]},
    ),
    "dpd_spring_repulsion": _with(
        CHAINS,
        spring_repulsion={"law": "exponential"},
        output={"observables": ["temperature", "pressure", "conformation", "spring_pairs"]},
    ),
    "dpd_jax_md_neighbors": _with(
        DUMBBELLS, neighbors={"method": "jax_md", "format": "ordered_sparse"}
    ),
    "lowe_andersen_rest": _with(DUMBBELLS, solvent=LOWE_ANDERSEN, integrator={"dt": 0.04}),
    "lowe_andersen_shear": _with(
        CHAINS, solvent=LOWE_ANDERSEN, integrator={"dt": 0.04}, flow=SHEAR
    ),
    "lowe_andersen_elongation": _with(
        {k: v for k, v in CHAINS.items() if k != "particles"},
        box=KR_BOX,
        particles={"density": 3.0, "species": DUMBBELLS["particles"]["species"]},
        solvent=LOWE_ANDERSEN,
        integrator={"dt": 0.04},
        flow=ELONGATION,
    ),
    "hoogerbrugge_koelman_rest": HK_FLUID,
    "hoogerbrugge_koelman_shear": _with(HK_FLUID, flow=HK_SHEAR),
    "hoogerbrugge_koelman_oscillatory_shear": _with(
        HK_FLUID, flow={**HK_SHEAR, "oscillation_frequency": 0.1}
    ),
    "hoogerbrugge_koelman_elongation": _with(
        {k: v for k, v in HK_FLUID.items() if k != "particles"},
        box=KR_BOX,
        particles={"density": 3.0, "species": HK_FLUID["particles"]["species"]},
        flow={"kind": "planar_elongation", "elongation_rate": 0.01},
    ),
    "mpcd_rest": MPCD,
    "mpcd_shear": _with(MPCD, flow=SHEAR),
    "mpcd_particle_collisions": _with(
        MPCD,
        particles={"count": 80, "species": [{"name": "monomer", "count": 80, "mass": 5.0}]},
        solvent={"method": "mpcd", "collision_time": 0.1, "kT": 1.0, "collision": "particle"},
    ),
    "lattice_boltzmann_wca_chain": _with(
        _packaged("lb_chain"),
        box={"lengths": [6.0, 6.0, 6.0]},
        particles={"count": 10, "species": [{"name": "monomer"}]},
        polymers=[
            {
                "species": "monomer",
                "beads": 10,
                "bond": {"law": "fene_log_wca", "spring_constant": 7.0, "max_extension": 2.0},
            }
        ],
    ),
}


def run(data: dict) -> dict:
    """Run `STEPS` steps of the scene; return the arrays to compare."""
    import jax

    jax.config.update("jax_enable_x64", True)
    from jaxdpd.engine.build import build
    from jaxdpd.scene import Scene

    data = copy.deepcopy(data)
    data.pop("run", None)
    data["output"] = {k: v for k, v in data.get("output", {}).items() if k != "path"}
    scene = Scene.from_dict(data)
    simulation = build(scene)
    state = simulation.init_fn()

    def body(state, _):
        return simulation.step_fn(state)

    state, samples = jax.jit(lambda s: jax.lax.scan(body, s, None, length=STEPS))(state)
    arrays = {
        "positions": state.positions,
        "velocities": state.velocities,
        "forces": state.forces,
        "image": state.image,
        "flags": state.flags,
    }
    for prefix, tree in (("sample", samples), ("observers", state.observers)):
        for path, leaf in jax.tree_util.tree_leaves_with_path(tree):
            arrays[f"{prefix}{jax.tree_util.keystr(path)}"] = leaf
    arrays = {name: np.asarray(value) for name, value in arrays.items()}
    arrays["scene"] = np.asarray(json.dumps(scene.to_dict(), sort_keys=True))
    return arrays


def compare(name: str, arrays: dict) -> tuple[bool, float]:
    """(bit-identical, largest relative difference) against the stored file."""
    stored = np.load(HERE / f"{name}.npz")
    if set(stored.files) != set(arrays):
        missing = set(stored.files) ^ set(arrays)
        raise AssertionError(f"{name}: arrays differ in name: {sorted(missing)}")
    identical, worst = True, 0.0
    for key in stored.files:
        old, new = stored[key], arrays[key]
        if old.shape != new.shape or old.dtype != new.dtype:
            raise AssertionError(
                f"{name}/{key}: {old.shape} {old.dtype} -> {new.shape} {new.dtype}"
            )
        if key == "scene":
            if old != new:
                raise AssertionError(f"{name}: the resolved scene changed")
        elif not np.array_equal(old, new, equal_nan=True):
            identical = False
            scale = max(float(np.max(np.abs(old))), 1e-300)
            worst = max(worst, float(np.max(np.abs(old.astype(float) - new))) / scale)
    return identical, worst


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--check", action="store_true", help="compare instead of recording")
    parser.add_argument("names", nargs="*", help="scenes (default: all)")
    args = parser.parse_args()
    failed = 0
    for name in args.names or SCENES:
        arrays = run(SCENES[name])
        if not args.check:
            np.savez_compressed(HERE / f"{name}.npz", **arrays)
            print(f"recorded {name}: {len(arrays)} arrays")
            continue
        identical, worst = compare(name, arrays)
        failed += not identical
        print(f"{name:32s} {'bit-identical' if identical else f'differs, max rel {worst:.2e}'}")
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
