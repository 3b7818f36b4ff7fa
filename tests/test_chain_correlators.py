"""The "dynamics" observable: multiple-tau correlators fed on device during a run.

Reference: at lags below the correlator's first coarse-grained level (0 … 15 samples)
the multiple-tau estimator is the plain all-origins average (Ramírez et al., J. Chem.
Phys. 133, 154103 (2010)), so it must equal the FFT estimators of
jaxdpd.analysis.dynamics applied to the same samples stored on the host, to float64
round-off (relative 1e-9 allows for the different summation orders).  Observers of a
batch (jaxdpd.run.ensemble) are those of its replicas run one by one (same seeds; vmapping
may reorder sums, so to round-off, 1e-9).
"""

import jax
import numpy as np
import pytest
from conftest import make_scene

from jaxdpd.analysis import conformation, dynamics
from jaxdpd.engine.build import build
from jaxdpd.observables.chain_correlators import chain_correlations, positional_autocorrelation
from jaxdpd.run import driver, ensemble

EVERY = 4
SAMPLES = 40
SINGLE_BEADS, DUMBBELLS = 8, 10
SEEDS = [5, 6]


@pytest.fixture(scope="module")
def run():
    """300 particles: 20 Hookean 3-bead chains ("chain"), one 8-bead FENE chain
    ("single") and 10 FENE dumbbells ("dumbbell") in solvent; "conformation" and
    "dynamics", 40 correlator samples.  Returns the simulation, the start and final
    states, the stored frames of each block at the sampled steps (unwrapped chains,
    wrapped dumbbells) and the per-chunk conformation series."""
    fene = {"law": "fene", "spring_constant": 3.0, "max_extension": 2.0}
    scene = make_scene(
        particles={
            "density": 3.0,
            "count": 300,
            "species": [
                {"name": "chain", "count": 60},
                {"name": "single", "count": SINGLE_BEADS},
                {"name": "dumbbell", "count": 2 * DUMBBELLS},
                {"name": "solvent", "count": 240 - SINGLE_BEADS - 2 * DUMBBELLS},
            ],
        },
        polymers=[
            {"species": "chain", "beads": 3, "bond": {"law": "hookean", "spring_constant": 3.0}},
            {"species": "single", "beads": SINGLE_BEADS, "bond": fene},
            {"species": "dumbbell", "beads": 2, "bond": fene},
        ],
        output={
            "observables": ["conformation", "dynamics"],
            "correlator_every": EVERY,
            "correlator_levels": 3,
        },
    )
    simulation = build(scene)
    # The step counter starts at 0 and is incremented before sampling, so samples fall
    # on steps EVERY, 2 EVERY, ...: the state after each chunk of EVERY steps.
    start = simulation.init_fn()
    frames = {"chain": [], "single": [], "dumbbell": []}
    series = []

    def keep(result):
        state = result.state
        unwrapped = simulation.box.unwrap(state.positions, state.image)
        for block in simulation.blocks:
            source = state.positions if block.species == "dumbbell" else unwrapped
            frames[block.species].append(np.asarray(block.take(source)))
        series.append(result.series)

    state = driver.run(simulation, start, EVERY * SAMPLES, EVERY, on_chunk=keep)
    frames = {name: np.stack(f) for name, f in frames.items()}  # (T, C, M, 3)
    return simulation, start, state, frames, series


def test_run_time_correlators_equal_stored_trajectory_estimators(run):
    simulation, _, state, frames, _ = run
    trajectory = frames["chain"]
    results = chain_correlations(state.observers, EVERY * simulation.scene.integrator.dt)
    lag_times, g3 = results["chain/g3"]
    np.testing.assert_allclose(
        lag_times[:16], np.arange(16) * EVERY * simulation.scene.integrator.dt
    )
    expected = {
        "chain/g1": dynamics.bead_msd(trajectory).mean(axis=1),
        "chain/g2": dynamics.relative_bead_msd(trajectory).mean(axis=1),
        "chain/g3": dynamics.center_of_mass_msd(trajectory).mean(axis=1),
    }
    end_to_end = trajectory[:, :, -1] - trajectory[:, :, 0]
    expected["chain/end_to_end_acf"] = (
        dynamics.time_autocorrelation(end_to_end).sum(axis=-1).mean(axis=1)
    )
    relative = trajectory - trajectory.mean(axis=2, keepdims=True)
    expected["chain/positional_acf"] = (
        dynamics.time_autocorrelation(relative).sum(axis=-1).mean(axis=(1, 2))
    )
    for name, reference in expected.items():
        values = results[name][1]
        measured = values.reshape(values.shape[0], -1).mean(axis=1)
        np.testing.assert_allclose(
            measured[:16], np.asarray(reference)[:16], rtol=1e-9, atol=1e-12, err_msg=name
        )
    assert np.all(np.isfinite(g3[:16]))


def test_single_chain_positional_autocorrelation_on_device(run):
    """On-device C(t) of one chain equals dynamics.positional_autocorrelation of the
    stored trajectory at the level-0 lags (round-off), its error is NaN (one chain, no
    jackknife), and the unnormalised lag-0 value averaged over the beads is ⟨R_g²⟩
    of the same frames (R_g² = (1/M) Σ_i |u_i|², conformation.gyration_radius_squared
    in its pair form)."""
    simulation, _, state, frames, _ = run
    trajectory = frames["single"]
    correlations = chain_correlations(state.observers, EVERY * simulation.scene.integrator.dt)
    lag_times, correlation, error = positional_autocorrelation(correlations)["single/C"]
    reference, reference_error = dynamics.positional_autocorrelation(trajectory)
    np.testing.assert_allclose(correlation[:16], np.asarray(reference)[:16], rtol=1e-9)
    assert np.all(np.isnan(error)) and np.all(np.isnan(np.asarray(reference_error)))
    _, per_bead = correlations["single/positional_acf"]
    gyration = np.asarray(conformation.gyration_radius_squared(trajectory)).mean()
    np.testing.assert_allclose(per_bead[0].mean(), gyration, rtol=1e-12)


def test_dumbbell_gyration_radius_series_is_a_quarter_of_the_spring_length(run):
    """For two beads r_cm is the midpoint, so R_g² = |Q|²/4 exactly: the per-step
    "conformation" series gyration_radius_sq equals bond_length_sq/4 at every step,
    and at each chunk's last step it equals |Q|²/4 from the wrapped positions by the
    minimum image (springs shorter than half the box), computed here on the host."""
    simulation, _, _, frames, series = run
    gyration = np.concatenate([s["dumbbell/gyration_radius_sq"] for s in series])
    bond = np.concatenate([s["dumbbell/bond_length_sq"] for s in series])
    assert gyration.shape == (EVERY * SAMPLES,)
    np.testing.assert_allclose(gyration, bond / 4, rtol=1e-12)
    spring = frames["dumbbell"][:, :, 1] - frames["dumbbell"][:, :, 0]
    edges = np.asarray(simulation.box.lengths)
    spring -= edges * np.round(spring / edges)
    host = np.sum(spring**2, axis=-1).mean(axis=1) / 4
    np.testing.assert_allclose(gyration[EVERY - 1 :: EVERY], host, rtol=1e-10)


def test_init_observers_on_a_batch_equals_the_replicas(run):
    """init_observers on a batch (leading replica axis) gives each replica the
    single-replica observers (they were a TypeError before), and chain_correlations
    of a batch merges the replicas into the chain axis."""
    simulation, start, _, _, _ = run
    batch = simulation.init_observers(ensemble.replicate(simulation, start, seeds=SEEDS))
    single = simulation.init_observers(start)
    for replica in ensemble.unstack(batch):
        jax.tree.map(np.testing.assert_array_equal, replica.observers, single.observers)
    interval = EVERY * simulation.scene.integrator.dt
    merged = chain_correlations(batch.observers, interval)
    for key, (lag_times, values) in chain_correlations(single.observers, interval).items():
        np.testing.assert_array_equal(merged[key][0], lag_times)
        assert merged[key][1].shape == (
            values.shape[0],
            len(SEEDS) * values.shape[1],
            *values.shape[2:],
        )


@pytest.mark.slow
def test_batch_observers_after_a_vmapped_chunk_equal_the_replicas_run_alone(run):
    """After a vmapped chunk each replica's correlators equal those of that replica run
    alone with the same seed, and so do its chains' slice of the batch's
    chain_correlations (about 40 s on 2 loaded cores: two more compilations)."""
    simulation, start, _, _, _ = run
    batch = simulation.init_observers(ensemble.replicate(simulation, start, seeds=SEEDS))
    batch, _, _ = driver.run_chunk(simulation, batch, EVERY)
    interval = EVERY * simulation.scene.integrator.dt
    merged = chain_correlations(batch.observers, interval)
    for k, (seed, replica) in enumerate(zip(SEEDS, ensemble.unstack(batch), strict=True)):
        alone, _, _ = driver.run_chunk(simulation, replica_start(start, seed), EVERY)
        jax.tree.map(
            lambda a, b: np.testing.assert_allclose(a, b, rtol=1e-9, atol=1e-12),
            replica.observers,
            alone.observers,
        )
        # chain_correlations of the batch: replica k's chains are the k-th slice.
        for key, (_, values) in chain_correlations(alone.observers, interval).items():
            chains = values.shape[1]
            np.testing.assert_allclose(
                merged[key][1][:, k * chains : (k + 1) * chains],
                values,
                rtol=1e-9,
                atol=1e-12,
                err_msg=key,
            )


def replica_start(state, seed):
    return state.set(seed=jax.numpy.asarray(seed, jax.numpy.uint32))
