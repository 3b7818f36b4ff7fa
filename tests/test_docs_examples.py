"""The documentation's code examples work, and its generated pages cover the schema.

A fenced ```python block in docs/ preceded by the line `<!-- test: run -->` is run:
the marked blocks of one page in order, in one namespace, in a temporary directory
holding a copy of examples/ (so pages may refer to examples/*.toml and write files).
Every other python block must at least compile.  The site itself is built by
`.ci/run` (`mkdocs build --strict`, the README's documentation command); this module
checks that the README's commands and `.ci/run` stay in step.
"""

import importlib.util
import re
import shutil
from pathlib import Path

import pytest

from jaxdpd.forces.bonds import BOND_LAWS
from jaxdpd.observables import OBSERVABLES
from jaxdpd.solvents import SOLVENTS

ROOT = Path(__file__).resolve().parent.parent
DOCS = ROOT / "docs"
MARK = "<!-- test: run -->"
BLOCK = re.compile(r"(?P<mark><!-- test: run -->\n)?```python\n(?P<code>.*?)```", re.S)


def python_blocks(page: Path) -> list[tuple[bool, str]]:
    """(marked to run, code) of each python block of a page, in order."""
    return [(m["mark"] is not None, m["code"]) for m in BLOCK.finditer(page.read_text())]


PAGES = sorted(DOCS.rglob("*.md"))
RUN_PAGES = [p for p in PAGES if MARK in p.read_text()]


def test_marks_precede_python_blocks():
    """A mark that is not directly followed by a python block would silently test nothing."""
    for page in RUN_PAGES:
        marks = page.read_text().count(MARK)
        assert marks == sum(run for run, _ in python_blocks(page)), page.name


@pytest.mark.parametrize("page", PAGES, ids=lambda p: str(p.relative_to(DOCS)))
def test_every_python_block_compiles(page):
    for index, (_, code) in enumerate(python_blocks(page)):
        compile(code, f"{page.name}[{index}]", "exec")


@pytest.mark.parametrize("page", RUN_PAGES, ids=lambda p: str(p.relative_to(DOCS)))
def test_marked_code_runs(page, tmp_path, monkeypatch):
    shutil.copytree(ROOT / "examples", tmp_path / "examples")
    monkeypatch.chdir(tmp_path)
    namespace = {"__name__": "__docs__"}
    for index, (run, code) in enumerate(python_blocks(page)):
        if run:
            exec(compile(code, f"{page.name}[{index}]", "exec"), namespace)


def _commands(text: str) -> list[str]:
    return [line for line in text.splitlines() if line.startswith("pip install")]


def test_ci_runs_exactly_the_readme_commands():
    """`.ci/run` runs the README's test command and its documentation command."""
    readme = _commands((ROOT / "README.md").read_text())
    ci = _commands((ROOT / ".ci" / "run").read_text())
    tests = [c for c in readme if "[test]" in c]
    docs = [c for c in readme if "[docs]" in c]
    assert len(tests) == 1 and len(docs) == 1
    assert tests[0] in ci and docs[0] in ci


def test_scene_reference_names_every_component_and_field():
    """The generated scene reference (docs/scene_reference.py) lists every registered
    solvent with each of its fields, every bond law and every observable."""
    spec = importlib.util.spec_from_file_location("scene_reference", DOCS / "scene_reference.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    page = module.render()
    for method in SOLVENTS:
        assert f"### `{method.name}`" in page
        section = page.split(f"### `{method.name}`")[1].split("###")[0]
        for name in method.fields:
            assert f"`{name}`" in section, (method.name, name)
    for name in (*BOND_LAWS.names(), *OBSERVABLES.names()):
        assert f"`{name}`" in page, name
