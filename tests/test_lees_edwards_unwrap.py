"""Unwrapped Lees–Edwards trajectories (issue 28, item 6).

The rule r + n · edges (jaxdpd.io.reader.read_unwrapped_positions) must give each
particle's continuous laboratory-frame path although the stored offset wraps from
+L_x/2 to −L_x/2 many times: the image counters are carried across each wrap
(LeesEdwardsBox.carry_images).  Reference for the MSD: at lags below the first
coarse level (0 … 15 samples) the multiple-tau correlator is the plain all-origins
average (Ramírez et al., J. Chem. Phys. 133, 154103 (2010)), so the on-device g3 must
equal the FFT estimator applied to the file's frames to float64 round-off.
"""

import jax.numpy as jnp
import numpy as np
import pytest
from conftest import scene_dict
from io_runs import polymer_reference_run, reference_run

from jaxdpd.analysis import dynamics
from jaxdpd.engine.build import build
from jaxdpd.geometry.boxes.lees_edwards import LeesEdwardsBox
from jaxdpd.io.reader import read_trajectory, read_unwrapped_positions
from jaxdpd.observables.chain_correlators import chain_correlations
from jaxdpd.run.runner import simulate
from jaxdpd.scene import Scene

EVERY = 4
SHEAR_RATE = 1.0


def _sheared_chain_scene(path):
    # L_x = L_y = 5: the offset grows by γ̇ L_y Δt = 0.2 per step and wraps every 25.
    data = scene_dict(
        particles={
            "count": 375,
            "species": [{"name": "chain", "count": 60}, {"name": "solvent", "count": 315}],
        },
        box={"lengths": [5.0, 5.0, 5.0]},
        flow={"kind": "shear", "shear_rate": SHEAR_RATE},
        polymers=[
            {"species": "chain", "beads": 3, "bond": {"law": "hookean", "spring_constant": 10.0}}
        ],
        run={"steps": 160, "chunk": EVERY, "equilibration": 0},
        output={
            "path": str(path),
            "observables": ["temperature", "dynamics"],
            "trajectory_every": EVERY,
            "correlator_every": EVERY,
            "correlator_levels": 3,
        },
    )
    del data["particles"]["density"]
    return Scene.from_dict(data)


def test_carry_images_keeps_unwrapped_positions_across_an_offset_wrap():
    box = LeesEdwardsBox((5.0, 5.0, 4.0), shear_rate=1.0)
    before = box.initial_state(jnp.float64).set(offset=jnp.asarray(2.4))
    after = box.advance(before, 0.0, 0.04)  # 2.4 + 0.2 wraps to −2.4
    assert float(after.offset) < 0
    positions = jnp.asarray([[1.0, 2.0, 3.0], [4.0, 1.0, 0.5]])
    image = jnp.asarray([[0, 2, 0], [1, -3, 1]], jnp.int32)
    carried = box.carry_images(image, before, after)
    expected = box.bind(before).unwrap(positions, image).at[:, 0].add(0.2 * image[:, 1])
    np.testing.assert_allclose(box.bind(after).unwrap(positions, carried), expected, atol=1e-12)


def _non_affine_steps(frames, scene):
    """|Δr − γ̇ (ȳ − L_y/2) Δt x̂| between consecutive unwrapped frames, ȳ the mean of
    the two frames' unwrapped y: the displacement less the streaming of the mean flow
    (which grows without bound with a particle's distance from the stagnation plane;
    the remainder is diffusion, ~ √(6 D Δt))."""
    values, times = frames.value, frames.time
    steps = np.diff(values, axis=0)
    height = 0.5 * (values[1:, :, 1] + values[:-1, :, 1]) - 0.5 * scene.box.lengths[1]
    steps[..., 0] -= scene.flow.shear_rate * height * np.diff(times)[:, None]
    return np.linalg.norm(steps, axis=-1)


def test_box_at_rest_unwraps_by_its_edge_lengths():
    """The I/O tests' periodic polymer run (built once per session): (3,) edges."""
    path = polymer_reference_run().path
    frames = read_unwrapped_positions(path)
    position = read_trajectory(path, "position").value.astype(np.float64)
    image = read_trajectory(path, "image").value
    edges = read_trajectory(path, "box/edges").value
    assert edges.shape == (len(position), 3)
    np.testing.assert_array_equal(frames.value, position + image * edges[:, None, :])


def test_shared_sheared_run_unwraps_without_jumps():
    """The I/O tests' sheared run (375 particles, L = 5, γ̇ = 0.5, frames every 20
    steps; built once per session): the offset wraps every 50 steps, 48 times."""
    run = reference_run()
    frames = read_unwrapped_positions(run.path)
    offsets = read_trajectory(run.path, "box/edges").value[:, 1, 0]
    assert np.sum(np.diff(offsets) < -2.5) >= 40
    assert np.abs(read_trajectory(run.path, "image").value[:, :, 1]).max() >= 1
    # Over 20 steps (0.8 τ) each component diffuses by σ ≈ √(2 D 0.8) ≈ 0.7 (D ≈ 0.3):
    # 4.5 r_c is beyond 6σ of the norm; a counter not carried across a wrap moves the
    # particle by n_y L_x, at least 5.
    assert _non_affine_steps(frames, run.scene).max() < 4.5


@pytest.mark.slow  # 40 chunks written to a file: about a minute on 2 busy cores
def test_sheared_trajectory_from_file_is_continuous_and_gives_the_device_g3(tmp_path):
    path = tmp_path / "sheared.h5"
    scene = _sheared_chain_scene(path)
    summary = simulate(scene, progress=False)
    frames = read_unwrapped_positions(path)
    image = read_trajectory(path, "image").value
    offsets = read_trajectory(path, "box/edges").value[:, 1, 0]
    # The run must exercise what it checks: offset wraps with particles that crossed y.
    assert np.sum(np.diff(offsets) < -2.5) >= 4
    assert np.abs(image[:, :, 1]).max() >= 1
    # Over 4 steps (0.16 τ) diffusion moves a particle by σ ≈ 0.3 per component.
    assert _non_affine_steps(frames, scene).max() < 2.0

    block = build(scene).blocks[0]
    chains = np.stack([np.asarray(block.take(jnp.asarray(frame))) for frame in frames.value])
    from_file = dynamics.center_of_mass_msd(chains).mean(axis=1)
    interval = EVERY * scene.integrator.dt
    lag_times, g3 = chain_correlations(summary.state.observers, interval)["chain/g3"]
    np.testing.assert_allclose(lag_times[:16], np.arange(16) * interval)
    np.testing.assert_allclose(g3[:16].mean(axis=1), from_file[:16], rtol=1e-9, atol=1e-12)
