"""`jaxdpd run SCENE -o OUTPUT -q` in this process, with one fault injected at the
N-th checkpoint (for tests/test_faults.py; the library itself has no test hooks).

    python fault_driver.py FAULT N SCENE OUTPUT

FAULT is one of:
    kill-writing-checkpoint  SIGKILL halfway through writing the N-th checkpoint's
                             temporary file (half its bytes are on disk)
    kill-before-rename       SIGKILL once the N-th checkpoint's temporary file is
                             written and fsynced, before it replaces the previous one
    kill-syncing-output      SIGKILL in the fsync of the output file that comes
                             before the N-th checkpoint (after HDF5's flush)
    fill-disk                once the N-th checkpoint is in place, a filler file is
                             written beside the output until the file system is full

The faults wrap os.write, os.replace and os.fsync, and act only on the files named
above (found through /proc/self/fd, so Linux only); everything else passes through.
"""

import errno
import os
import signal
import sys
from pathlib import Path

from jaxdpd.run.cli import main

TEMPORARY = ".checkpoint.tmp"


def _path_of(descriptor: int) -> str:
    try:
        return os.readlink(f"/proc/self/fd/{descriptor}")
    except OSError:
        return ""


def _kill() -> None:
    os.kill(os.getpid(), signal.SIGKILL)


def _fill(folder: Path) -> None:
    """Write a filler file in `folder` until its file system refuses (ENOSPC)."""
    block = b"\0" * 2**16
    descriptor = os.open(folder / "filler", os.O_WRONLY | os.O_CREAT | os.O_APPEND)
    try:
        while True:
            os.write(descriptor, block)
    except OSError as error:
        if error.errno != errno.ENOSPC:
            raise
    finally:
        os.close(descriptor)


def inject(fault: str, n: int, output: Path) -> None:
    """Wrap os.write, os.replace and os.fsync to inject `fault` at checkpoint `n`."""
    write, replace, fsync = os.write, os.replace, os.fsync
    done = [0]  # checkpoints in place so far

    def faulty_write(descriptor, data):
        if fault == "kill-writing-checkpoint" and done[0] == n - 1:
            if _path_of(descriptor).endswith(TEMPORARY):
                write(descriptor, bytes(data)[: len(data) // 2])
                fsync(descriptor)
                _kill()
        return write(descriptor, data)

    def faulty_replace(source, target):
        if str(source).endswith(TEMPORARY):
            if fault == "kill-before-rename" and done[0] == n - 1:
                _kill()
            replace(source, target)
            done[0] += 1
            if fault == "fill-disk" and done[0] == n:
                _fill(output.parent)
            return
        replace(source, target)

    def faulty_fsync(descriptor):
        if fault == "kill-syncing-output" and done[0] == n - 1:
            if _path_of(descriptor) == str(output.resolve()):
                _kill()
        fsync(descriptor)

    os.write, os.replace, os.fsync = faulty_write, faulty_replace, faulty_fsync


if __name__ == "__main__":
    fault, n, scene, output = sys.argv[1], int(sys.argv[2]), sys.argv[3], Path(sys.argv[4])
    inject(fault, n, output)
    sys.exit(main(["run", scene, "-o", str(output), "-q"]))
