"""jaxdpd: simulations of polymer solutions in mesoscale solvents, from scene files.

    jaxdpd run SCENE.toml [-o FILE] [--steps N] [--devices D] [-q] [--overwrite]
    jaxdpd run --restart FILE [-o COPY] [--steps N] [-q] [--overwrite]
    jaxdpd demo [-o FILE] [-q] [--overwrite]      (writes demo.h5md without -o)
    jaxdpd summary RUN.h5md         the summary table with units, glossary, blocking check
    jaxdpd plot RUN.h5md [-o DIR] [--format png|pdf]   figures (needs the `plot` extra)
    jaxdpd export RUN.h5md --format gsd|xyz|lammps-data [-o OUT] [--frames SPEC]
                  [--atom-style bond|full]
    jaxdpd --version

An existing output file (or COPY) is never replaced without --overwrite: the command
stops before building anything, naming the file, what it holds and the options.

Exit status: 0 done; 2 invalid input (scene, file or arguments, including a file to
restart that is damaged or incomplete; one line on stderr names the problem); 3 the
simulation became invalid (the last good state is checkpointed); 4 the output could
not be written (disk full, I/O error; the last checkpoint is intact and the command
that resumes it is printed); 128 + signal number (130 for SIGINT, 143 for SIGTERM)
when a signal stopped the run, after the chunk in flight, with a checkpoint and the
command that resumes it.  SIGINT and SIGTERM are handled even when the shell started
jaxdpd with them ignored (a background job); Ctrl-C before the run starts or after
it ended exits 130 without a traceback.
"""

# JAX and the engine are imported when a subcommand needs them, not for --help.

import argparse
import shlex
import shutil
import signal
import sys
import time
from importlib import resources
from pathlib import Path

from jaxdpd import __version__
from jaxdpd.decomposition.host_devices import request_host_devices

DEMO_SCENE = "demo.toml"
DEMO_OUTPUT = "demo.h5md"  # where `jaxdpd demo` writes without -o
INVALID_INPUT = 2
SIMULATION_FAILED = 3
OUTPUT_FAILED = 4


def demo_scene():
    """The embedded default scene (jaxdpd/scenes/demo.toml) as a Scene."""
    from jaxdpd.scene import Scene

    text = resources.files("jaxdpd.scenes").joinpath(DEMO_SCENE).read_text()
    return Scene.from_toml_string(text)


def prepare(scene, output_path=None, **options):
    """jaxdpd.run.runner.prepare, imported when a run is prepared (JAX loads then)."""
    from jaxdpd.run.runner import prepare as prepare_run

    return prepare_run(scene, output_path, **options)


def _describe(scene) -> str:
    s = scene
    return (
        f"{s.solvent.method} solvent, N = {s.n_particles}, ρ = {s.particles.density:.4g}, "
        f"box = {' × '.join(f'{x:.4g}' for x in s.box.lengths)}, dt = {s.integrator.dt}, "
        f"{s.run.equilibration} + {s.run.steps} steps, {s.precision}"
    )


def _prepare(args):
    """(the prepared Run, its output path) from the command line; raises on bad input."""
    from jaxdpd.io.checkpoint import checkpoint_path
    from jaxdpd.io.reader import read_scene
    from jaxdpd.run.overwrite import refuse_existing
    from jaxdpd.run.runner import prepare_resume
    from jaxdpd.scene import Scene

    options = {"progress": not args.quiet}
    if args.command == "demo":
        path = args.output or DEMO_OUTPUT
        if args.output is None:
            print(f"jaxdpd: writing {path} (give -o FILE to write elsewhere)", file=sys.stderr)
        return prepare(demo_scene(), path, overwrite=args.overwrite, **options), path
    if args.restart is not None:
        if args.scene is not None:
            raise ValueError("give a scene file or --restart FILE, not both")
        path = args.restart
        if args.output is not None and args.output != path:
            # Continue in the copy, keep the original.
            if not args.overwrite:
                refuse_existing(args.output)
            shutil.copyfile(path, args.output)
            shutil.copyfile(checkpoint_path(path), checkpoint_path(args.output))
            path = args.output
        request_host_devices(read_scene(path).parallel.devices)
        return prepare_resume(path, args.steps, **options), path
    if args.scene is None:
        raise ValueError("give a scene file (jaxdpd run SCENE.toml) or --restart FILE")
    scene = Scene.from_toml(args.scene)
    if args.steps is not None:
        scene = scene.replace(run={"steps": args.steps})
    if args.devices is not None:
        scene = scene.replace(parallel={"devices": args.devices})
    if args.author is not None:
        scene = scene.replace(output={"author": args.author})
    request_host_devices(scene.parallel.devices)
    path = args.output or scene.output.path
    return prepare(scene, args.output, overwrite=args.overwrite, **options), path


def _step_count(text: str) -> int:
    """A number of steps given on the command line (argparse names the option)."""
    try:
        steps = int(text)
    except ValueError:
        steps = -1
    if steps < 0:
        raise argparse.ArgumentTypeError(f"{text!r}: give a whole number of steps ≥ 0")
    return steps


def _resume_hint(path) -> str:
    return f"resume with:\n  jaxdpd run --restart {shlex.quote(str(path))}"


def _last_checkpoint(path) -> str:
    """Where a run that stopped on a write failure can be resumed from."""
    from jaxdpd.io.checkpoint import checkpoint_path, read_checkpoint_info
    from jaxdpd.io.errors import RunFileError

    try:
        info = read_checkpoint_info(path)
    except RunFileError:
        return "no checkpoint was written before the failure: the run must start again"
    return (
        f"the checkpoint of step {info.step} ({checkpoint_path(path)}) is intact; remove "
        f"the cause (free space), then {_resume_hint(path)}"
    )


def _execute(run, path) -> int:
    from jaxdpd.engine.errors import SimulationError
    from jaxdpd.io.checkpoint import checkpoint_path
    from jaxdpd.io.errors import OutputError
    from jaxdpd.run.driver import RunInterrupted

    print(f"jaxdpd: {_describe(run.scene)}", file=sys.stderr)
    start = time.perf_counter()
    try:
        summary = run.execute()
    except SimulationError as error:
        where = f"; last good state checkpointed in {checkpoint_path(path)}" if path else ""
        print(f"jaxdpd: run stopped: {error}{where}", file=sys.stderr)
        return SIMULATION_FAILED
    except OutputError as error:
        print(f"jaxdpd: output failed: {error}\njaxdpd: {_last_checkpoint(path)}", file=sys.stderr)
        return OUTPUT_FAILED
    except RunInterrupted as interrupt:
        print(f"jaxdpd: {interrupt}", file=sys.stderr)
        if path:
            print(
                f"jaxdpd: checkpoint written to {checkpoint_path(path)}; {_resume_hint(path)}",
                file=sys.stderr,
            )
        else:
            print("jaxdpd: no output file was given, so the run cannot be resumed", file=sys.stderr)
        return 128 + signal.Signals[interrupt.signal_name].value
    print(summary.table())
    print(f"total wall time {time.perf_counter() - start:.1f} s (compilation included)")
    if path:
        print(f"output written to {path}")
    return 0


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(
        prog="jaxdpd", description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument("--version", action="version", version=f"jaxdpd {__version__}")
    commands = parser.add_subparsers(dest="command", required=True)
    run = commands.add_parser("run", help="run a scene file, or continue a run")
    run.add_argument("scene", nargs="?", help="scene TOML file")
    run.add_argument(
        "--restart", metavar="FILE", help="continue the run checkpointed in FILE (appends to it)"
    )
    run.add_argument("-o", "--output", help="H5MD output file (overrides output.path)")
    run.add_argument("--steps", type=_step_count, help="override run.steps (production steps)")
    run.add_argument(
        "--devices",
        type=int,
        metavar="D",
        help="decompose the system into D slabs, one per device (overrides "
        "parallel.devices; on a CPU host, D CPU devices are made available)",
    )
    run.add_argument("-q", "--quiet", action="store_true", help="no progress bar")
    run.add_argument(
        "--overwrite",
        action="store_true",
        help="replace an existing output file (finished run or not) instead of refusing",
    )
    run.add_argument("--author", help="author name in the H5MD file (overrides output.author)")
    demo = commands.add_parser("demo", help="run the embedded default scene")
    demo.add_argument("-o", "--output", help=f"H5MD output file (default {DEMO_OUTPUT})")
    demo.add_argument("-q", "--quiet", action="store_true", help="no progress bar")
    demo.add_argument(
        "--overwrite",
        action="store_true",
        help="replace an existing output file (finished run or not) instead of refusing",
    )
    add_file_commands(commands)
    args = parser.parse_args(argv)
    if args.command in FILE_COMMANDS:
        return FILE_COMMANDS[args.command](args)
    ignored = signal.getsignal(signal.SIGINT) is signal.SIG_IGN
    if ignored:
        # Started in the background: kill -INT should still stop the run (at start-up
        # too), as Ctrl-C does in the foreground.  Put back on return.
        signal.signal(signal.SIGINT, signal.default_int_handler)
    try:
        return _run(args)
    except KeyboardInterrupt:
        # Before the run (building, compiling, opening files) or after it: nothing
        # to checkpoint.  During the run, SignalGuard turns SIGINT into a stop.
        print(
            "\njaxdpd: interrupted by SIGINT before the first chunk or after the last "
            "(no checkpoint written for it)",
            file=sys.stderr,
        )
        return 128 + signal.SIGINT
    finally:
        if ignored:
            signal.signal(signal.SIGINT, signal.SIG_IGN)


def _run(args) -> int:
    """Prepare and execute the command; the exit status."""
    from jaxdpd.io.errors import OutputError

    try:
        prepared, path = _prepare(args)
    except (ValueError, TypeError, OSError) as error:
        print(f"jaxdpd: invalid input: {error}", file=sys.stderr)
        return INVALID_INPUT
    except OutputError as error:
        print(f"jaxdpd: output failed: {error}", file=sys.stderr)
        return OUTPUT_FAILED
    return _execute(prepared, path)


# -- commands that read a run file -----------------------------------------------------
def add_file_commands(commands) -> None:
    """The subcommands that read a finished (or interrupted) run: summary, plot, export."""
    summary = commands.add_parser(
        "summary", help="print a run file's summary table with units, glossary and error check"
    )
    summary.add_argument("file", help="H5MD file written by jaxdpd")
    plot = commands.add_parser("plot", help="draw a run file's figures (PNG or PDF)")
    plot.add_argument("file", help="H5MD file written by jaxdpd")
    plot.add_argument(
        "-o", "--output", metavar="DIR", help="folder for the figures (default: the file's)"
    )
    plot.add_argument("--format", choices=("png", "pdf"), default="png", help="figure format")
    export = commands.add_parser(
        "export", help="write a run's frames as GSD, extended XYZ or a LAMMPS data file"
    )
    export.add_argument("file", metavar="RUN", help="H5MD file of a run (with frames)")
    # Formats and atom styles are checked by the format modules, which --help need not load.
    export.add_argument("--format", required=True, help="gsd, xyz or lammps-data")
    export.add_argument(
        "-o", "--output", help="file to write (default: RUN with the format's extension)"
    )
    export.add_argument(
        "--frames",
        metavar="SPEC",
        help="all, last, an index or a slice start:stop:step (default: all; last for lammps-data)",
    )
    export.add_argument(
        "--atom-style", default="bond", help="of a LAMMPS data file: bond (default) or full"
    )


def _summary(args) -> int:
    from jaxdpd.analysis.file_summary import summarize

    print(summarize(args.file))
    return 0


def _plot(args) -> int:
    try:
        import matplotlib  # noqa: F401
    except ImportError:
        print("jaxdpd: plot needs matplotlib: pip install 'jaxdpd[plot]'", file=sys.stderr)
        return INVALID_INPUT
    from jaxdpd.analysis.plots import plot_run

    try:
        written = plot_run(args.file, args.output, args.format)
    except OSError as error:  # the folder cannot be made or written
        print(f"jaxdpd: invalid input: {error}", file=sys.stderr)
        return INVALID_INPUT
    for path in written:
        print(path)
    if not written:
        print(f"jaxdpd: {args.file} holds nothing to plot", file=sys.stderr)
    return 0


def _export(args) -> int:
    from jaxdpd.io.export import export
    from jaxdpd.io.formats import format_of

    try:
        module = format_of(args.file, args.format, field="--format")
        output = args.output or str(Path(args.file).with_suffix(module.extensions[0]))
        options = {name: getattr(args, name) for name in module.write_options}
        count = export(args.file, output, args.format, args.frames, **options)
    except (ValueError, OSError, ImportError) as error:
        print(f"jaxdpd: invalid input: {error}", file=sys.stderr)
        return INVALID_INPUT
    print(f"{count} frame(s) of {args.file} written to {output} ({args.format})")
    return 0


def _reading(command):
    """`command(args)` with a file that cannot be read reported as invalid input."""

    def run(args) -> int:
        from jaxdpd.io.errors import RunFileError

        try:
            return command(args)
        except RunFileError as error:
            print(f"jaxdpd: invalid input: {error}", file=sys.stderr)
            return INVALID_INPUT

    return run


FILE_COMMANDS = {
    "summary": _reading(_summary),
    "plot": _reading(_plot),
    "export": _reading(_export),
}


if __name__ == "__main__":
    sys.exit(main())
