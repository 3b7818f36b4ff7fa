"""Lattice Boltzmann with beads in steady and oscillatory shear, as a scene: from a
TOML file through the command line and from Python, restarts, momentum of beads and
fluid, and the combinations that remain refused."""

import jax.numpy as jnp
import numpy as np
import pytest
from io_runs import assert_same_leaves

from jaxdpd.engine.build import build
from jaxdpd.run import driver
from jaxdpd.run.cli import main
from jaxdpd.run.restore import restore
from jaxdpd.run.runner import resume, simulate
from jaxdpd.scene import Scene
from jaxdpd.solvents.lattice_boltzmann import fluid_parameters
from jaxdpd.solvents.lattice_boltzmann.integrator import fluid_momentum
from jaxdpd.validation import SceneError

# A Kremer–Grest chain of 10 beads in a 6³ fluctuating fluid (the lb_chain parameters),
# sheared at γ̇ = 0.2; τ = 5 Δt.
SHEARED_CHAIN_TOML = """
seed = 11
precision = "float64"

[box]
lengths = [6.0, 6.0, 6.0]

[particles]
count = 10
species = [{ name = "monomer" }]

[solvent]
method = "lattice_boltzmann"
kT = 1.2
grid_spacing = 1.0
time_step = 0.05
mass_density = 0.864
kinematic_viscosity = 2.8
friction = 31.473

[pair]
kind = "wca"
epsilon = 1.0
sigma = 1.0

[[polymers]]
species = "monomer"
beads = 10
bond = { law = "fene_log_wca", spring_constant = 7.0, max_extension = 2.0 }

[integrator]
dt = 0.01

[neighbors]
method = "cell_list"

[flow]
kind = "shear"
shear_rate = 0.2

[run]
equilibration = 0
steps = 60
chunk = 20

[output]
observables = ["temperature", "conformation"]
checkpoint_every = 20
"""


def sheared_chain() -> Scene:
    return Scene.from_toml_string(SHEARED_CHAIN_TOML)


class _Crash(RuntimeError):
    pass


def test_a_sheared_lb_scene_file_runs_and_its_restart_is_bit_identical(tmp_path):
    """`jaxdpd run SCENE.toml` runs the sheared chain; a run that dies after 40 steps
    (20 past its last checkpoint) and is resumed from the checkpoint ends with every
    leaf of the state bit-identical to the run that went straight on: the fluid's
    populations, velocity and pending impulse and the Lees–Edwards offset are in the
    checkpoint (jaxdpd.io.checkpoint stores every SimState leaf)."""
    scene_file = tmp_path / "sheared.toml"
    scene_file.write_text(SHEARED_CHAIN_TOML)
    straight = tmp_path / "straight.h5"
    assert main(["run", str(scene_file), "-o", str(straight), "-q"]) == 0
    _, expected = restore(straight)
    assert float(expected.box_state.offset) != 0

    def crash(result):
        if int(result.state.step) == 40:
            raise _Crash

    interrupted = tmp_path / "interrupted.h5"
    with pytest.raises(_Crash):
        simulate(sheared_chain(), interrupted, progress=False, on_chunk=crash)
    resume(interrupted, progress=False)
    assert_same_leaves(restore(interrupted)[1], expected)


def _bead_lab_momentum(state, scene) -> np.ndarray:
    """Σ (c + u_s) over the beads (unit masses) with u_s = γ̇ (y − L_y/2) at the
    unwrapped y: the laboratory momentum, continuous through boundary crossings."""
    ly = scene.box.lengths[1]
    unwrapped_y = np.asarray(state.positions[:, 1]) + ly * np.asarray(state.image[:, 1])
    rate = float(state.box_state.shear_rate)
    lab = np.asarray(state.velocities).copy()
    lab[:, 0] += rate * (unwrapped_y - 0.5 * ly)
    return lab.sum(axis=0)


def test_chain_and_sheared_fluid_conserve_momentum_to_round_off():
    """Bonds and pairs are antisymmetric, the friction impulse goes to the fluid with
    the opposite sign (through the Lees–Edwards images of the beads too), the lattice
    collision conserves momentum, and the sheared boundary's interpolation keeps the
    sum over every layer: so beads + fluid + pending impulse keep their y and z
    momentum to float64 round-off (1e-12 of Σ|p|) over 400 steps with beads near and
    across the boundary.  Along x the boundary itself changes the momentum of the
    populations that cross it (Galilean shift, Wagner & Pagonabarraga 2002) in the
    LB steps; between them (τ = 5 Δt) nothing else may: the beads' laboratory
    momentum (continuous through their crossings) plus the fluid's is constant to
    round-off over the four MD steps after an LB step."""
    scene = sheared_chain()
    simulation = build(scene)
    fluid = fluid_parameters(scene)
    state = simulation.init_fn()
    # Move the chain across the sheared boundary (half a box up; forces unchanged).
    bound = simulation.box.bind(state.box_state)
    positions, image = bound.wrap(state.positions + jnp.asarray([0.0, 3.0, 0.0]), state.image)
    state = state.set(positions=positions, image=image)

    def total(state):
        return _bead_lab_momentum(state, scene) + np.asarray(
            fluid_momentum(fluid, state.solvent_state)
        )

    def scale(state):
        populations = np.abs(np.asarray(state.solvent_state.deviations)).sum()
        return np.abs(np.asarray(state.velocities)).sum() + fluid.lattice_speed * populations

    before = total(state)
    near_boundary = 0
    for _ in range(20):
        state, _, _ = driver.run_chunk(simulation, state, 20)
        y = np.asarray(state.positions[:, 1])
        near_boundary += int(np.sum((y < 0.5) | (y > 5.5)))
    assert int(state.flags) == 0 and int(state.step) == 400 and near_boundary > 20
    after = total(state)
    np.testing.assert_allclose(after[1:], before[1:], rtol=0, atol=1e-12 * scale(state))
    start = total(state)  # step 400 ended with an LB step; the next is at 405
    state, _, _ = driver.run_chunk(simulation, state, 4)
    np.testing.assert_allclose(total(state)[0], start[0], rtol=0, atol=1e-12 * scale(state))


# A Hookean dumbbell in a 4³ fluid in oscillatory shear (no pair forces: cheap to build).
OSCILLATORY_DUMBBELL_TOML = """
seed = 3
precision = "float64"

[box]
lengths = [4.0, 4.0, 4.0]

[particles]
count = 2
species = [{ name = "bead" }]

[solvent]
method = "lattice_boltzmann"
kT = 1.0
grid_spacing = 1.0
time_step = 0.05
mass_density = 1.0
kinematic_viscosity = 1.0
friction = 10.0

[[polymers]]
species = "bead"
beads = 2
bond = { law = "hookean", spring_constant = 2.0 }

[integrator]
dt = 0.01

[neighbors]
method = "cell_list"

[flow]
kind = "shear"
shear_rate = 0.5
oscillation_frequency = 2.0
"""


def test_oscillatory_shear_runs_from_a_scene_file_in_python(tmp_path):
    """A dumbbell in oscillatory shear γ̇(t) = γ̇₀ cos ωt, read from a TOML file and run
    from Python: the box clock sets the phase (offset ∫ γ̇ L_y dt = γ̇₀ L_y sin(ωt)/ω,
    midpoint rule: relative error O((ωΔt)²) ≈ 1e-4), the fluid stays valid and the y
    and z momentum of beads plus fluid is conserved to round-off."""
    scene_file = tmp_path / "oscillatory.toml"
    scene_file.write_text(OSCILLATORY_DUMBBELL_TOML)
    scene = Scene.from_toml(scene_file)
    simulation = build(scene)
    fluid = fluid_parameters(scene)
    state = simulation.init_fn()

    def transverse(state):
        beads = np.asarray(state.velocities).sum(axis=0)
        return (beads + np.asarray(fluid_momentum(fluid, state.solvent_state)))[1:]

    before = transverse(state)
    for _ in range(2):
        state, _, _ = driver.run_chunk(simulation, state, 20)
    assert int(state.flags) == 0
    assert abs(float(state.box_state.time) - 0.4) < 1e-12
    expected_offset = 0.5 * 4.0 * np.sin(2.0 * 0.4) / 2.0
    assert abs(float(state.box_state.offset) - expected_offset) < 1e-3 * expected_offset
    np.testing.assert_allclose(transverse(state), before, rtol=0, atol=1e-12)


def test_lattice_boltzmann_in_planar_elongation_is_refused_naming_the_fields():
    """Planar elongation of a lattice is not implemented (docs/solvent_flows/
    lattice_boltzmann.md says why): the scene names flow.kind and solvent.method."""
    data = sheared_chain().to_dict()
    data["flow"] = {"kind": "planar_elongation", "elongation_rate": 0.1}
    with pytest.raises(SceneError, match="flow.kind") as caught:
        Scene.from_dict(data)
    assert "lattice_boltzmann" in str(caught.value) and "shear" in str(caught.value)
