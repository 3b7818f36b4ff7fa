"""One file and one registry line per component: a toy solvent, a toy bond law and a
toy observable, defined and registered here, run through Scene.from_dict → build →
steps (docs/extending.md quotes these classes).

Each is checked against an exact expectation: the ballistic solvent's particles move
as x(t) = x0 + v t, wrapped; the toy bond law's forces are −∇U of its energy; the toy
observable's per-step samples equal ½ ⟨m v_x²⟩ of the states, through the runner's
H5MD file.  The fixture unregisters them afterwards.
"""

import pathlib
import re
from dataclasses import dataclass
from typing import ClassVar

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from jaxdpd.engine.build import build
from jaxdpd.forces.bonds import BOND_LAWS, BondLaw, Parameter
from jaxdpd.io import read_observable
from jaxdpd.observables import OBSERVABLES
from jaxdpd.observables.component import Observable
from jaxdpd.run.runner import simulate
from jaxdpd.scene import Scene
from jaxdpd.solvents import SOLVENTS, SolventMethod, SolventParameters
from jaxdpd.validation import read_number


# -- a toy solvent: free streaming --------------------------------------------------
@dataclass(frozen=True)
class BallisticParameters(SolventParameters):
    """solvent.method = "ballistic": only kT, the temperature the velocities start at."""

    method: ClassVar[str] = "ballistic"


class Ballistic(SolventMethod):
    """Free streaming x ← x + v Δt, wrapped into the box: no forces, no thermostat."""

    name = "ballistic"
    pair_forces = False  # no [pair] section
    sets_temperature = False  # kT is only the starting temperature
    integrator_lambda = False  # no integrator.lambda
    initial_forces = False  # the state's forces stay zero

    def read(self, section) -> BallisticParameters:
        return BallisticParameters(
            kT=read_number(section, "kT", "solvent", 1.0, minimum=0, exclusive_minimum=True)
        )

    def to_dict(self, parameters) -> dict:
        return {"method": self.name, "kT": parameters.kT}

    def example_scene(self, precision="float64") -> dict:
        return {
            "seed": 1,
            "precision": precision,
            "box": {"lengths": [4.0, 4.0, 4.0]},
            "particles": {"count": 50},
            "solvent": {"method": "ballistic"},
            "integrator": {"dt": 0.1},
        }

    def advance(self, context):
        dt = jnp.asarray(context.scene.integrator.dt, context.dtype)

        def step(state):
            moved = state.positions + dt * state.velocities
            positions, image = context.box.wrap(moved, state.image)
            return state.set(
                positions=positions, image=image, step=state.step + 1, time=state.time + dt
            )

        return step


# -- a toy bond law: U = ¼ c Q⁴ ------------------------------------------------------
class ToyQuartic(BondLaw):
    """U = ¼ c Q⁴, so the tension per length T/Q = c Q² (in q² = Q²: c q²)."""

    name = "toy_quartic"
    parameters = {"c": Parameter(2.0)}

    def stiffness(self, q_sq, c):
        return c * q_sq

    def energy(self, q_sq, c):
        return 0.25 * c * q_sq * q_sq

    def placement_length(self, values, kT):
        return 0.8


# -- a toy observable: the mean kinetic energy along x -------------------------------
class KineticX(Observable):
    """½ ⟨m v_x²⟩ per particle, sampled after every step."""

    name = "kinetic_x"
    units = {"kinetic_x": "k_BT"}

    def sampler(self, context):
        masses = 1.0 if context.masses is None else context.masses

        def sample(previous, state):
            return state, {"kinetic_x": 0.5 * jnp.mean(masses * state.velocities[:, 0] ** 2)}

        return sample


@pytest.fixture(scope="module", autouse=True)
def toys():
    """Register the toys (one line each) for this module's tests, then remove them."""
    SOLVENTS.register(Ballistic())
    BOND_LAWS.register(ToyQuartic())
    OBSERVABLES.register(KineticX())
    yield
    SOLVENTS.unregister("ballistic")
    BOND_LAWS.unregister("toy_quartic")
    OBSERVABLES.unregister("kinetic_x")


def scan(simulation, state, steps: int):
    return jax.jit(
        lambda s: jax.lax.scan(lambda c, _: simulation.step_fn(c), s, None, length=steps)
    )(state)


def test_ballistic_solvent_streams_freely():
    """x(t) = x0 + v t exactly up to the round-off of t/Δt additions (≤ steps · ε · |x|
    per step, ε = 2⁻⁵²); positions stay in [0, L); velocities (and so the momentum)
    are untouched."""
    scene = Scene.from_dict(Ballistic().example_scene())
    simulation = build(scene)
    start = simulation.init_fn()
    steps = 40
    state, _ = scan(simulation, start, steps)
    lengths = np.asarray(scene.box.lengths)
    unwrapped = np.asarray(state.positions) + np.asarray(state.image) * lengths
    expected = np.asarray(start.positions) + np.asarray(start.velocities) * steps * 0.1
    scale = float(np.max(np.abs(expected)))
    np.testing.assert_allclose(unwrapped, expected, rtol=0, atol=4 * steps * 2**-52 * scale)
    assert np.all((np.asarray(state.positions) >= 0) & (np.asarray(state.positions) < lengths))
    assert np.any(np.asarray(state.image) != 0)  # some particle crossed the box
    np.testing.assert_array_equal(state.velocities, start.velocities)
    assert float(state.time) == pytest.approx(steps * 0.1, rel=1e-12)


def test_toy_bond_law_drives_the_chains():
    """Chains of the toy law under a thermostat-free DPD step (γ = 0, no [pair]): the
    forces are −∇U of Σ ¼ c Q⁴ over the springs (jax.grad, float64 round-off), and the
    total momentum stays zero to round-off (internal forces)."""
    data = {
        "seed": 3,
        "precision": "float64",
        "box": {"lengths": [5.0, 5.0, 5.0]},
        "particles": {"count": 20, "species": [{"name": "bead"}]},
        "solvent": {"method": "dpd", "gamma": 0.0},
        "polymers": [{"species": "bead", "beads": 10, "bond": {"law": "toy_quartic", "c": 3.0}}],
        "integrator": {"dt": 0.01},
    }
    scene = Scene.from_dict(data)
    assert scene.to_dict()["polymers"][0]["bond"] == {"law": "toy_quartic", "c": 3.0}
    simulation = build(scene)
    state, _ = scan(simulation, simulation.init_fn(), 20)
    lengths = jnp.asarray(scene.box.lengths)

    def energy(unwrapped):
        springs = unwrapped.reshape(2, 10, 3)
        q_sq = jnp.sum((springs[:, 1:] - springs[:, :-1]) ** 2, axis=-1)
        return jnp.sum(0.25 * 3.0 * q_sq**2)

    unwrapped = state.positions + state.image * lengths
    expected = -jax.grad(energy)(unwrapped)
    np.testing.assert_allclose(state.forces, expected, rtol=1e-12, atol=1e-12)
    assert float(jnp.max(jnp.abs(expected))) > 0.1  # the springs are stretched
    np.testing.assert_allclose(np.sum(np.asarray(state.velocities), axis=0), 0, atol=1e-12)


def test_toy_observable_through_the_runner(tmp_path):
    """The toy observable's series, written by the runner into the H5MD file and read
    back, is ½ ⟨v_x²⟩ of the ballistic particles, whose velocities never change: one
    exact value at every step."""
    data = Ballistic().example_scene()
    data["run"] = {"steps": 10, "chunk": 5}
    data["output"] = {"observables": ["kinetic_x"]}
    scene = Scene.from_dict(data)
    simulate(scene, tmp_path / "toy.h5", progress=False)
    series = read_observable(tmp_path / "toy.h5", "kinetic_x")
    velocities = np.asarray(build(scene).init_fn().velocities)
    expected = 0.5 * np.mean(velocities[:, 0] ** 2)
    assert np.shape(series.value)[0] > 0
    np.testing.assert_allclose(series.value, expected, rtol=1e-14)


def test_the_extending_guide_quotes_this_file():
    """Every Python block of docs/extending.md is verbatim in this file, so the guide
    shows code that these tests run."""
    here = pathlib.Path(__file__)
    guide = (here.parent.parent / "docs" / "extending.md").read_text()
    blocks = re.findall(r"```python\n(.*?)```", guide, flags=re.DOTALL)
    assert len(blocks) >= 6  # three classes and their three register lines
    source = here.read_text()
    for block in blocks:
        assert block.strip() in source, block
