"""Every shipped scene in examples/ validates and builds as shipped and runs a few
steps (tests/example_runs.py says how).  This file runs the examples at rest and in
planar elongation, tests/test_examples_shear.py those in shear; a failure names the
file.  The examples are documented in the docs site ("Examples", generated from
their header comments).
"""

import pytest
from example_runs import EXAMPLES, in_shear, run_example

from jaxdpd.engine.build import build
from jaxdpd.scene import Scene
from jaxdpd.solvents import SOLVENTS


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
    """Validation, resource checks (for the shipped run length) and the composed
    step, without compiling."""
    simulation = build(Scene.from_toml(path))
    assert callable(simulation.step_fn), path.name


@pytest.mark.parametrize("path", [p for p in EXAMPLES if not in_shear(p)], ids=lambda p: p.stem)
def test_example_runs_a_few_steps(path, tmp_path):
    run_example(path, tmp_path / "run.h5md")
