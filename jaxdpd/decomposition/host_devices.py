"""CPU devices for a decomposed run on one host.

JAX's CPU backend offers one device unless XLA_FLAGS asks for more when the backend
starts (the first computation, not `import jax`).  The command line asks for the
devices a scene needs before anything runs; a Python user sets XLA_FLAGS before
the first computation (docs/scaling_out.md).
"""

import os

FLAG = "--xla_force_host_platform_device_count"


def request_host_devices(count: int) -> None:
    """Ask for `count` CPU devices unless XLA_FLAGS already sets a number (no effect
    once the CPU backend has started, nor on GPU devices)."""
    flags = os.environ.get("XLA_FLAGS", "")
    if count > 1 and FLAG not in flags:
        os.environ["XLA_FLAGS"] = f"{flags} {FLAG}={count}".strip()
