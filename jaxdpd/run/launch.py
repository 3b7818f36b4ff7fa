"""Start P local processes of one command, joined into one JAX distributed runtime.

    python -m jaxdpd.run.launch --processes 2 -- \\
        python -m jaxdpd.run.distributed scene.toml --seeds 1 2 --flow-rates 0 0.5

Each process gets JAXDPD_COORDINATOR=127.0.0.1:<a free port>, JAXDPD_PROCESS_COUNT=P
and JAXDPD_PROCESS_ID=k, which `jaxdpd.run.distributed.initialize()` reads; process
0 hosts the coordination service on the loopback interface only.  SIGINT and
SIGTERM are passed on to every process (each stops after its chunk in flight, with
checkpoints).  On several hosts, start one process per host with those three
variables set instead (docs/multi_process_ensembles.md).

Exit status: 0 when every process exits 0, else the first nonzero status; when one
process fails, the others get SIGTERM after `grace` seconds, so none waits forever
in a collective for a process that is gone.
"""

import argparse
import os
import signal
import socket
import subprocess
import sys
import time

from jaxdpd.run.distributed import COORDINATOR, PROCESS_COUNT, PROCESS_ID


def free_port() -> int:
    """A TCP port on the loopback interface that nothing listens on now."""
    with socket.socket() as probe:
        probe.bind(("127.0.0.1", 0))
        return probe.getsockname()[1]


def launch(command: list, processes: int, port: int | None = None, **popen) -> list:
    """Start `processes` copies of `command` (argv list) with the distributed
    environment; `popen` goes to subprocess.Popen (stdout, env, cwd, ...).
    Returns the Popen objects, process 0 first."""
    if processes < 1:
        raise ValueError(f"--processes = {processes}: give at least 1")
    base = dict(popen.pop("env", None) or os.environ)
    base[COORDINATOR] = f"127.0.0.1:{port or free_port()}"
    base[PROCESS_COUNT] = str(processes)
    return [
        # A session of its own: a Ctrl-C at the terminal reaches the launcher only,
        # which passes it on once (a second SIGINT would stop a run without checkpoints).
        subprocess.Popen(command, env={**base, PROCESS_ID: str(k)}, start_new_session=True, **popen)
        for k in range(processes)
    ]


def wait(children: list, grace: float = 60.0) -> int:
    """Wait for every child; the first nonzero exit status, or 0.  Once one has
    failed, those still running after `grace` seconds get SIGTERM."""
    status, deadline = 0, None
    while [child.poll() for child in children].count(None):  # poll() every child
        if deadline is None and (codes := [c.returncode for c in children if c.returncode]):
            status, deadline = codes[0], time.monotonic() + grace
        if deadline is not None and time.monotonic() > deadline:
            for child in children:
                if child.poll() is None:
                    child.terminate()
            deadline = float("inf")
        time.sleep(0.1)
    return status or next((c.returncode for c in children if c.returncode), 0)


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(
        prog="python -m jaxdpd.run.launch",
        description=__doc__,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    parser.add_argument("-n", "--processes", type=int, required=True)
    parser.add_argument("--port", type=int, help="coordinator port (default: a free one)")
    parser.add_argument("command", nargs=argparse.REMAINDER, help="-- COMMAND ARGS ...")
    args = parser.parse_args(argv)
    command = args.command[1:] if args.command[:1] == ["--"] else args.command
    if not command:
        parser.error("give the command to start after --")
    children = launch(command, args.processes, args.port)

    def forward(signum, _frame):
        for child in children:
            if child.poll() is None:
                child.send_signal(signum)

    for signum in (signal.SIGINT, signal.SIGTERM):
        signal.signal(signum, forward)
    return wait(children)


if __name__ == "__main__":
    sys.exit(main())
