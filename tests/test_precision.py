"""64-bit JAX types are switched on by what needs them, never by `import jaxdpd`.

Each check runs in a fresh interpreter: this test session itself has them on
(tests/conftest.py).
"""

import os
import subprocess
import sys
import textwrap


def run_fresh(code: str) -> None:
    """Run `code` in a new Python process with this checkout first on the path."""
    root = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
    path = os.pathsep.join(p for p in (root, os.environ.get("PYTHONPATH")) if p)
    environment = {**os.environ, "PYTHONPATH": path}
    environment.pop("JAX_ENABLE_X64", None)
    result = subprocess.run(
        [sys.executable, "-c", textwrap.dedent(code)],
        capture_output=True,
        text=True,
        env=environment,
        timeout=300,
    )
    assert result.returncode == 0, result.stderr


def test_import_leaves_jax_32_bit_and_a_float64_scene_switches_64_bit_on():
    run_fresh(
        """
        import jax, jax.numpy as jnp
        import jaxdpd, jaxdpd.analysis.rheology, jaxdpd.brownian, jaxdpd.io.h5md
        import jaxdpd.run.runner
        from jaxdpd.engine.build import build
        from jaxdpd.scene import Scene

        assert not jax.config.jax_enable_x64
        data = {
            "seed": 1,
            "precision": "float64",
            "particles": {"density": 3.0, "count": 375},
            "solvent": {"method": "dpd", "kT": 1.0, "gamma": 4.5},
            "pair": {"a": 25.0},
            "integrator": {"dt": 0.04},
        }
        state = build(Scene.from_dict(data)).init_fn()
        assert jax.config.jax_enable_x64
        for name in ("positions", "velocities", "forces"):
            assert getattr(state, name).dtype == jnp.float64, name
        """
    )


def test_float64_input_to_brownian_and_analysis_keeps_float64():
    """The Brownian entry points default to float64 and the host-side estimators keep
    a float64 NumPy series float64, each switching 64-bit types on itself."""
    run_fresh(
        """
        import jax, jax.numpy as jnp, numpy as np
        from jaxdpd import brownian as bd
        from jaxdpd.analysis.statistics import block_average

        state = bd.equilibrium_state(jax.random.key(0), bd.FENE(50.0), 8)
        assert state.connector.dtype == jnp.float64
        jax.config.update("jax_enable_x64", False)
        mean, error = block_average(np.linspace(0.0, 1.0, 40), n_blocks=4)
        assert mean.dtype == error.dtype == jnp.float64
        """
    )
