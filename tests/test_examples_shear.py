"""The shipped examples in steady and oscillatory shear run a few steps
(tests/example_runs.py; the others run in tests/test_examples.py)."""

import pytest
from example_runs import EXAMPLES, in_shear, run_example


@pytest.mark.parametrize("path", [p for p in EXAMPLES if in_shear(p)], ids=lambda p: p.stem)
def test_example_runs_a_few_steps(path, tmp_path):
    run_example(path, tmp_path / "run.h5md")
