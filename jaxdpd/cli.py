"""Command line: `jaxdpd run SCENE.toml`, `jaxdpd demo`."""

import argparse
import sys
import time
from importlib import resources

from jaxdpd.errors import SimulationError
from jaxdpd.runner import simulate
from jaxdpd.scene import Scene

DEMO_SCENE = "demo.toml"


def demo_scene() -> Scene:
    """The embedded default scene (jaxdpd/scenes/demo.toml)."""
    text = resources.files("jaxdpd.scenes").joinpath(DEMO_SCENE).read_text()
    return Scene.from_toml_string(text)


def _describe(scene: Scene) -> str:
    s = scene
    return (
        f"{s.solvent.method} solvent, N = {s.n_particles}, ρ = {s.particles.density:.4g}, "
        f"box = {' × '.join(f'{x:.4g}' for x in s.box.lengths)}, dt = {s.integrator.dt}, "
        f"{s.run.equilibration} + {s.run.steps} steps, {s.precision}"
    )


def _run(scene: Scene, output, quiet: bool) -> int:
    print(f"jaxdpd: {_describe(scene)}", file=sys.stderr)
    start = time.perf_counter()
    try:
        summary = simulate(scene, output_path=output, progress=not quiet)
    except SimulationError as error:
        where = (
            f"; last good state checkpointed in {output or scene.output.path}"
            if (output or scene.output.path)
            else ""
        )
        print(f"jaxdpd: run stopped: {error}{where}", file=sys.stderr)
        return 3
    print(summary.table())
    print(f"total wall time {time.perf_counter() - start:.1f} s (compilation included)")
    target = output or scene.output.path
    if target:
        print(f"output written to {target}")
    return 0


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(prog="jaxdpd", description=__doc__)
    commands = parser.add_subparsers(dest="command", required=True)
    run = commands.add_parser("run", help="run a scene file")
    run.add_argument("scene", help="scene TOML file")
    run.add_argument("-o", "--output", help="H5MD output file (overrides output.path)")
    run.add_argument("--steps", type=int, help="override run.steps")
    run.add_argument("-q", "--quiet", action="store_true", help="no progress bar")
    demo = commands.add_parser("demo", help="run the embedded default scene")
    demo.add_argument("-o", "--output", help="H5MD output file")
    demo.add_argument("-q", "--quiet", action="store_true", help="no progress bar")
    args = parser.parse_args(argv)
    try:
        if args.command == "demo":
            scene = demo_scene()
        else:
            scene = Scene.from_toml(args.scene)
            if args.steps is not None:
                scene = scene.replace(run={"steps": args.steps})
    except (ValueError, TypeError, OSError) as error:
        print(f"jaxdpd: invalid scene: {error}", file=sys.stderr)
        return 2
    return _run(scene, args.output, args.quiet)


if __name__ == "__main__":
    sys.exit(main())
