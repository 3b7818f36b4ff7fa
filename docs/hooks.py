"""MkDocs hooks: pages and files the site takes from outside docs/.

- `scene_reference.md`, generated from the scene schema (docs/scene_reference.py);
- `examples.md`, generated from the header comments of examples/*.toml;
- `notebooks/*.ipynb` from the repository's notebooks/ (rendered, not executed, by
  mkdocs-jupyter, which this hook runs before);
- `figures/*.png` from benchmarks/results/ (the benchmark plots the pages show).
"""

import importlib.util
import os
import sys
from pathlib import Path

from mkdocs.plugins import event_priority
from mkdocs.structure.files import File

ROOT = Path(__file__).resolve().parent.parent
# Document the checkout being built, whatever jaxdpd the environment has installed.
sys.path.insert(0, os.fspath(ROOT))


def _load(name: str):
    spec = importlib.util.spec_from_file_location(name, Path(__file__).with_name(f"{name}.py"))
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def _header(path: Path) -> str:
    """The leading comment block of a scene file, as text."""
    lines = []
    for line in path.read_text().splitlines():
        if not line.startswith("#"):
            break
        lines.append(line.lstrip("#").strip())
    return " ".join(lines)


def examples_page() -> str:
    out = [
        "# Examples",
        "",
        "Complete, commented scenes in `examples/`, one per solvent and flow the package "
        "supports and one per system of the physics sources. Run one with",
        "",
        "```bash",
        "jaxdpd run examples/dpd_fluid.toml -o dpd_fluid.h5md",
        "```",
        "",
        "(`--steps N` shortens a run). Each is run for a few steps by the default "
        "tests (`tests/test_examples.py`, `tests/test_examples_shear.py`). Generated "
        "from the files' header comments.",
        "",
        "| file | what |",
        "|---|---|",
    ]
    for path in sorted((ROOT / "examples").glob("*.toml")):
        out.append(f"| `examples/{path.name}` | {_header(path)} |")
    return "\n".join(out) + "\n"


@event_priority(100)  # before mkdocs-jupyter converts the notebooks
def on_files(files, config):
    files.append(
        File.generated(config, "scene_reference.md", content=_load("scene_reference").render())
    )
    files.append(File.generated(config, "examples.md", content=examples_page()))
    # A plain File rooted at the repository (mkdocs-jupyter cannot read generated ones).
    for notebook in sorted((ROOT / "notebooks").glob("*.ipynb")):
        files.append(
            File(
                f"notebooks/{notebook.name}",
                os.fspath(ROOT),
                config.site_dir,
                config.use_directory_urls,
            )
        )
    for figure in sorted((ROOT / "benchmarks" / "results").glob("*.png")):
        files.append(
            File.generated(config, f"figures/{figure.name}", abs_src_path=os.fspath(figure))
        )
    return files
