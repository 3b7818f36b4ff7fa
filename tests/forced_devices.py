"""Run a probe script in a fresh Python process and read the JSON it prints.

JAX fixes its CPU device count when it starts, so a comparison on D forced host
devices (XLA_FLAGS=--xla_force_host_platform_device_count=D, which each probe sets
before importing JAX) runs in its own process.
"""

import json
import os
import subprocess
import sys
from pathlib import Path


def run_probe(script: Path, arguments: list, timeout: float = 900) -> dict:
    """The JSON `script` prints when run with `arguments` (the repository on its
    Python path); a failing run fails the calling test with the end of its stderr."""
    environment = {**os.environ, "PYTHONPATH": str(script.parent.parent)}
    completed = subprocess.run(
        [sys.executable, str(script), *arguments],
        capture_output=True,
        text=True,
        env=environment,
        timeout=timeout,
    )
    assert completed.returncode == 0, completed.stderr[-3000:]
    return json.loads(completed.stdout)
