"""Bad input to the Brownian-dynamics API is refused with a ValueError naming the
argument, before anything is traced."""

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from jaxdpd.brownian import (
    FENE,
    Hookean,
    equilibrium_state,
    fit_spring,
    flow_curve,
    likelihood_ratio_sensitivity,
    simulate,
    state_from_connectors,
    stationary_average,
    velocity_gradient,
)
from jaxdpd.brownian.dynamics import predictor_corrector

KEY = jax.random.key(0)
KAPPA = velocity_gradient("shear", 1.0)


def _flow_curve(**overrides):
    kwargs = dict(
        key=KEY, flow="shear", rates=[1.0], spring=FENE(50.0), n_dumbbells=64, dt=0.01,
        n_equilibrate=0, n_samples=4, sample_every=1, n_blocks=4,
    )  # fmt: skip
    kwargs.update(overrides)
    return flow_curve(**kwargs)


@pytest.mark.parametrize(
    ("overrides", "match"),
    [
        ({"spring": FENE(0.0)}, "FENE.b"),
        ({"spring": FENE(-5.0)}, "FENE.b"),
        ({"spring": FENE(np.inf)}, "FENE.b"),
        ({"spring": "fene"}, "spring"),
        ({"dt": -0.01}, "dt"),
        ({"dt": 0.0}, "dt"),
        ({"flow": "couette"}, "flow"),
        ({"rates": [1.0, -2.0]}, "rates"),
        ({"rates": [[1.0]]}, "rates"),
        ({"n_dumbbells": 0}, "n_dumbbells"),
        ({"n_dumbbells": 65}, "n_blocks"),
        ({"n_samples": 2.5}, "n_samples"),
        ({"n_equilibrate": -1}, "n_equilibrate"),
        ({"dtype": jnp.int32}, "dtype"),
        ({"dtype": jnp.float16}, "dtype"),
        ({"noise": "uniform"}, "noise"),
        ({"blocks": "replicas"}, "blocks"),
        ({"blocks": "time", "n_samples": 2, "n_blocks": 4}, "n_samples"),
    ],
)
def test_flow_curve_refuses_bad_input(overrides, match):
    with pytest.raises(ValueError, match=match):
        _flow_curve(**overrides)


def test_velocity_gradient_refuses_bad_input():
    with pytest.raises(ValueError, match="flow must be one of"):
        velocity_gradient("extension", 1.0)
    with pytest.raises(ValueError, match="rate"):
        velocity_gradient("shear", -1.0)
    with pytest.raises(ValueError, match="rate"):
        velocity_gradient("shear", np.nan)
    with pytest.raises(ValueError, match="dtype"):
        velocity_gradient("shear", 1.0, dtype=np.int64)


def test_simulate_and_state_refuse_bad_input():
    state = state_from_connectors(jnp.zeros((8, 3), jnp.float64), FENE(50.0))
    with pytest.raises(ValueError, match="dt"):
        simulate(KEY, state, KAPPA, FENE(50.0), -1.0, n_samples=1)
    with pytest.raises(ValueError, match="n_samples"):
        simulate(KEY, state, KAPPA, FENE(50.0), 0.01, n_samples=0)
    with pytest.raises(ValueError, match="FENE.b"):
        simulate(KEY, state, KAPPA, FENE(-1.0), 0.01, n_samples=1)
    with pytest.raises(ValueError, match="noise"):
        simulate(KEY, state, KAPPA, FENE(50.0), 0.01, n_samples=1, noise="white")
    with pytest.raises(ValueError, match="n_dumbbells"):
        equilibrium_state(KEY, FENE(50.0), 0)
    with pytest.raises(ValueError, match="FENE.b"):
        equilibrium_state(KEY, FENE(0.0), 8)
    with pytest.raises(ValueError, match="dt"):
        predictor_corrector(Hookean(), -0.1)


def test_no_silent_downcast_of_kappa():
    """A float64 kappa for a float32 ensemble is refused, not silently cast."""
    state32 = state_from_connectors(jnp.zeros((8, 3), jnp.float32), FENE(50.0))
    with pytest.raises(ValueError, match="kappa has dtype float64"):
        simulate(KEY, state32, KAPPA, FENE(50.0), 0.01, n_samples=1)


def test_sensitivity_and_fit_refuse_bad_input():
    with pytest.raises(ValueError, match="n_average"):
        stationary_average(KEY, FENE(50.0), KAPPA, 0.01, n_dumbbells=8, n_burn=0, n_average=0)
    with pytest.raises(ValueError, match="FENE.b"):
        stationary_average(KEY, FENE(-2.0), KAPPA, 0.01, n_dumbbells=8, n_burn=0, n_average=1)
    with pytest.raises(ValueError, match="n_blocks"):
        likelihood_ratio_sensitivity(
            KEY, FENE(50.0), KAPPA, 0.01, n_dumbbells=10, n_burn=0, n_samples=4,
            sample_every=1, window=2, n_blocks=4,
        )  # fmt: skip
    with pytest.raises(ValueError, match="window"):
        likelihood_ratio_sensitivity(
            KEY, FENE(50.0), KAPPA, 0.01, n_dumbbells=8, n_burn=0, n_samples=4,
            sample_every=1, window=0, n_blocks=4,
        )  # fmt: skip
    with pytest.raises(ValueError, match="b_start"):
        fit_spring(KEY, [], -3.0, n_dumbbells=8, dt=0.01, n_burn=0, n_average=1)
    with pytest.raises(ValueError, match="targets"):
        fit_spring(KEY, [], 20.0, n_dumbbells=8, dt=0.01, n_burn=0, n_average=1)
