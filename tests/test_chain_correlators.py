"""The "dynamics" observable: multiple-tau correlators fed on device during a run.

Reference: at lags below the correlator's first coarse-grained level (0 … 15 samples)
the multiple-tau estimator is the plain all-origins average (Ramírez et al., J. Chem.
Phys. 133, 154103 (2010)), so it must equal the FFT estimators of
jaxdpd.observables.dynamics applied to the same samples stored on the host, to float64
round-off (relative 1e-9 allows for the different summation orders).
"""

import numpy as np
from conftest import make_scene

from jaxdpd import driver
from jaxdpd.observables import dynamics
from jaxdpd.observables.chain_correlators import chain_correlations
from jaxdpd.simulation import build

EVERY = 4
SAMPLES = 40


def test_run_time_correlators_equal_stored_trajectory_estimators():
    scene = make_scene(
        particles={
            "density": 3.0,
            "count": 300,
            "species": [{"name": "chain", "count": 60}, {"name": "solvent", "count": 240}],
        },
        polymers=[
            {"species": "chain", "beads": 3, "bond": {"law": "hookean", "spring_constant": 3.0}}
        ],
        output={"observables": ["dynamics"], "correlator_every": EVERY, "correlator_levels": 3},
    )
    simulation = build(scene)
    # The step counter starts at 0 and is incremented before sampling, so samples fall
    # on steps EVERY, 2 EVERY, ...: the state after each chunk of EVERY steps.
    state = simulation.init_fn()
    frames = []

    def keep(result):
        unwrapped = simulation.box.unwrap(result.state.positions, result.state.image)
        frames.append(np.asarray(simulation.blocks[0].take(unwrapped)))

    state = driver.run(simulation, state, EVERY * SAMPLES, EVERY, on_chunk=keep)
    trajectory = np.stack(frames)  # (T, C, M, 3)
    results = chain_correlations(state.observers, EVERY * scene.integrator.dt)

    lag_times, g3 = results["chain/g3"]
    np.testing.assert_allclose(lag_times[:16], np.arange(16) * EVERY * scene.integrator.dt)
    expected = {
        "chain/g1": dynamics.bead_msd(trajectory).mean(axis=1),
        "chain/g2": dynamics.relative_bead_msd(trajectory).mean(axis=1),
        "chain/g3": dynamics.center_of_mass_msd(trajectory).mean(axis=1),
    }
    end_to_end = trajectory[:, :, -1] - trajectory[:, :, 0]
    expected["chain/end_to_end_acf"] = (
        dynamics.time_autocorrelation(end_to_end).sum(axis=-1).mean(axis=1)
    )
    for name, reference in expected.items():
        values = results[name][1]
        measured = values.reshape(values.shape[0], -1).mean(axis=1)
        np.testing.assert_allclose(
            measured[:16], np.asarray(reference)[:16], rtol=1e-9, atol=1e-12, err_msg=name
        )
    assert np.all(np.isfinite(g3[:16]))
