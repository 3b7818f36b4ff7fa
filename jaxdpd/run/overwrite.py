"""A new run never replaces an existing file without being told to.

LAMMPS overwrites its output silently and GROMACS renames the old file to
`#name.1#`; jaxdpd refuses before building anything, naming the file, what it holds,
and the ways on: continue it (`jaxdpd run --restart FILE`, `--steps N` to extend a
finished run), replace it (`--overwrite`; `overwrite=True` from Python), or write
elsewhere (`-o FILE`).  Refusing keeps every finished run where its user left it and
leaves no backups to clean up.
"""

import shlex
from pathlib import Path

FINISHED = "end of run"  # the checkpoint reason of a run that completed


def holds(path) -> str:
    """What the existing file `path` holds, in words, and how it can be continued."""
    from jaxdpd.io.checkpoint import read_checkpoint_info
    from jaxdpd.io.errors import RunFileError

    try:
        info = read_checkpoint_info(path)
    except RunFileError:
        return "no jaxdpd checkpoint beside it: it cannot be continued"
    if info.reason == FINISHED:
        return f"a finished run, checkpointed at step {info.step}"
    return f"an unfinished run, checkpointed at step {info.step}: {info.reason}"


def refuse_existing(path) -> None:
    """Raise FileExistsError if `path` exists, naming it, what it holds and the options."""
    if not Path(path).exists():
        return
    held = holds(path)
    resume = (
        ""
        if held.startswith("no jaxdpd")
        else f"continue it with `jaxdpd run --restart {shlex.quote(str(path))}` "
        "(--steps N extends a finished run), "
    )
    raise FileExistsError(
        f"{path} already exists ({held}) and was left untouched; {resume}replace it "
        "with --overwrite (from Python: overwrite=True), or write elsewhere with -o FILE"
    )
