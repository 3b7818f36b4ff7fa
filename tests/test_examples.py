"""Every shipped scene in examples/ validates and builds as shipped and runs a few steps.

Each file is read exactly as `jaxdpd run examples/X.toml` reads it; only the run
length is shortened (no equilibration, STEPS production steps in one chunk, one
frame) and the output goes to a temporary H5MD file, through the runner the command
line calls.  A failure names the file.  The examples are documented in the docs site
("Examples", generated from their header comments).

Compiling a scene costs 15–40 s of CPU on the shared 2-core machine (its step, its
initial forces and its observers), so the default run runs one example per solvent
(DEFAULT_RUN; the getting-started page's test, tests/test_docs_examples.py, runs
examples/dpd_fluid.toml) and builds every one without compiling; `-m slow` runs all.
"""

import math
from pathlib import Path

import h5py
import pytest

from jaxdpd.engine.build import build
from jaxdpd.run.runner import simulate
from jaxdpd.scene import Scene
from jaxdpd.solvents import SOLVENTS

EXAMPLES = sorted((Path(__file__).resolve().parent.parent / "examples").glob("*.toml"))
STEPS = 2
# Run in the default test run: one example of each solvent, the seeds' systems among
# them (FENE dumbbells in shear, thesis ch. 4; the Kremer–Grest chain in lattice
# Boltzmann; Mussawisade et al. 2005's chain in SRD) and a flow for each of the
# others; examples/dpd_fluid.toml runs in tests/test_docs_examples.py.  All 19 run
# under -m slow (about 17 s of compilation each on a cold cache).
DEFAULT_RUN = (
    "dpd_fene_dumbbells_shear",
    "lowe_andersen_shear",
    "hoogerbrugge_koelman_planar_elongation",
    "lattice_boltzmann_chain",
    "mpcd_zimm_chain",
)


def shortened(scene: Scene) -> Scene:
    """The scene with STEPS production steps in one chunk and a frame at the end."""
    return scene.replace(
        run={"equilibration": 0, "steps": STEPS, "chunk": STEPS},
        output={"trajectory_every": STEPS, "checkpoint_every": 0},
    )


def test_every_solvent_and_declared_flow_has_an_example():
    """One example per (solvent, flow) its component declares, and one at rest."""
    covered = set()
    for path in EXAMPLES:
        scene = Scene.from_toml(path)
        flow = None if scene.flow is None else scene.flow.kind
        if flow == "shear" and scene.flow.oscillation_frequency is not None:
            flow = "oscillatory_shear"
        covered.add((scene.solvent.method, flow))
    for method in SOLVENTS:
        flows = [None, *method.flows] + (["oscillatory_shear"] if "shear" in method.flows else [])
        for flow in flows:
            assert (method.name, flow) in covered, f"no example of {method.name} in {flow}"


@pytest.mark.parametrize("path", EXAMPLES, ids=lambda p: p.stem)
def test_example_builds(path):
    """Validation, resource checks and the composed step, without compiling."""
    simulation = build(Scene.from_toml(path))
    assert callable(simulation.step_fn), path.name


@pytest.mark.parametrize(
    "path",
    [pytest.param(p, marks=() if p.stem in DEFAULT_RUN else pytest.mark.slow) for p in EXAMPLES],
    ids=lambda p: p.stem,
)
def test_example_runs_a_few_steps(path, tmp_path):
    scene = shortened(Scene.from_toml(path))
    output = tmp_path / "run.h5md"
    summary = simulate(scene, output, progress=False)
    temperature, _ = summary.averages["temperature"]
    assert math.isfinite(temperature) and temperature > 0, path.name
    with h5py.File(output, "r") as handle:
        assert handle["particles/trajectory/position/value"].shape[0] == 1, path.name
