"""The solvent component: what one solvent method owns, from its scene section to its step.

A solvent method is one `SolventMethod` object, registered in `jaxdpd.solvents.SOLVENTS`
under the name a scene gives as `solvent.method`.  The scene (jaxdpd.scene) and the
engine (jaxdpd.engine.build) only look it up and call it; neither names a method.

What a method provides (attributes are capabilities, methods are hooks):

Scene section
    name                      the value of solvent.method
    fields                    its scene fields besides method and kT (fields of other
                              methods are refused with the owner's name)
    read(section)             the validated section as the method's frozen parameter
                              dataclass (a `SolventParameters`: `.method`, `.kT`, ...)
    to_dict(parameters)       the resolved section, as `Scene.to_dict` writes it
    default_dt(parameters)    integrator.dt when the scene gives none
    check_integrator(parameters, section, integrator)
                              its rules on integrator.dt and integrator.lambda
    pair_range(parameters, cutoff)
                              (field, value) of the longest pair range it needs
    check(scene)              its checks across sections on the assembled scene
    step_time(scene)          simulated time per step
    memory(scene, box_volume, itemsize)
                              {field: bytes} of its own device arrays
    example_scene(precision)  a small valid scene dict (a few hundred particles at
                              most) that runs in seconds: the contract tests
                              (tests/test_solvent_contracts.py) run every registered
                              method through it

Capabilities
    flows                     the flow kinds it has a step for
    pair_forces               whether a [pair] force may act
    body_forces               whether a [body_force] may act
    integrator_lambda         whether integrator.lambda is one of its fields
    conserves_particle_momentum
                              whether the particles' total momentum is constant
    sets_temperature          whether solvent.kT is a set temperature (else only the
                              starting one)
    heating_advice            what to change when the measured temperature drifts
    unavailable_observables   {observable: why it cannot be measured}
    uses_neighbor_list        whether it reads the particle pair list itself
    initial_forces            whether the initial state holds the forces of its
                              positions (False for a step that computes its own)
    decomposition             how a decomposed run steps it ("forces_after_drift",
                              "forces_before_flight"), or None where it cannot

Engine hooks
    pair_terms(scene, dtype)  pair terms it adds after the [pair] law
    bath_cutoff(scene)        the reach of a pair thermostat beyond the pair terms, or
                              None
    force_range(scene, blocks)
                              (first, stop) of the particles that feel forces
    advance(context)          `advance(state) -> state`, one step, from a StepContext
    initial_solvent_state(scene, dtype)
                              SimState.solvent_state at the start (None for none)
"""

from collections.abc import Callable, Mapping
from dataclasses import dataclass
from types import MappingProxyType
from typing import ClassVar

NOISE_LAWS = ("uniform", "gaussian")


@dataclass(frozen=True)
class SolventParameters:
    """The validated [solvent] section; each method subclasses it with its fields.

    Attributes:
        method: the method's name (class-level).
        kT: k_BT, the set temperature (for a method that sets none, the temperature
            the velocities start at).
    """

    method: ClassVar[str]
    kT: float = 1.0


@dataclass(frozen=True)
class StepContext:
    """What a solvent's `advance` is built from.

    Attributes:
        scene: the Scene.
        box: its static box (jaxdpd.geometry.boxes).
        interactions: the force kernel (jaxdpd.engine.build.force_kernel).
        masses: (N,) particle masses or None (unit masses).
        force_range: (first, stop) of the particles the kernel covers.
        search: the neighbour backend (None without pair terms or thermostat).
        with_virial: whether the pressure is observed.
        dtype: floating dtype.
        ownership: in a decomposed run, the rows the stepping device owns and the
            sum over devices (jaxdpd.engine.ownership), for the sums a step takes
            over the system; None on one device.
    """

    scene: object
    box: object
    interactions: Callable
    masses: object
    force_range: tuple[int, int]
    search: object
    with_virial: bool
    dtype: object
    ownership: object = None


class SolventMethod:
    """Base of the solvent components: defaults of every capability and hook (see the
    module docstring).  A method sets `name`, `fields`, `read`, `to_dict` and
    `advance`, and overrides what differs."""

    name: ClassVar[str]
    fields: ClassVar[tuple[str, ...]] = ()
    flows: ClassVar[tuple[str, ...]] = ()
    pair_forces: ClassVar[bool] = True
    body_forces: ClassVar[bool] = False
    integrator_lambda: ClassVar[bool] = True
    conserves_particle_momentum: ClassVar[bool] = True
    sets_temperature: ClassVar[bool] = True
    heating_advice: ClassVar[str] = ""
    unavailable_observables: ClassVar[Mapping[str, str]] = MappingProxyType({})
    uses_neighbor_list: ClassVar[bool] = False
    initial_forces: ClassVar[bool] = True
    # How a decomposed run (jaxdpd.decomposition) steps the method's particles, or None
    # where it cannot: "forces_after_drift" (velocity Verlet: the halo must hold every
    # particle that may come within reach during the step, parallel.margin) or
    # "forces_before_flight" (the step reads the positions the halo was sent with).
    decomposition: ClassVar[str | None] = None

    # -- scene section ------------------------------------------------------------
    def read(self, section: dict) -> SolventParameters:
        raise NotImplementedError

    def to_dict(self, parameters) -> dict:
        raise NotImplementedError

    def default_dt(self, parameters) -> float:
        return 0.04

    def check_integrator(self, parameters, section: dict, integrator) -> None:
        """Refuse integrator fields that do not fit the method."""

    def pair_range(self, parameters, cutoff: float) -> tuple[str, float]:
        return "cutoff", cutoff

    def check(self, scene) -> None:
        """Checks across sections of the assembled scene."""

    def step_time(self, scene) -> float:
        return scene.integrator.dt

    def memory(self, scene, box_volume: float, itemsize: int) -> dict:
        return {}

    def example_scene(self, precision: str = "float64") -> dict:
        """A minimal valid scene dict of this method in `precision` ("float32" or
        "float64"), small enough for a contract test to run it in seconds."""
        raise NotImplementedError(
            f"solvent method {self.name!r} provides no example_scene(precision); "
            "the contract tests (tests/test_solvent_contracts.py) need one"
        )

    # -- engine -------------------------------------------------------------------
    def pair_terms(self, scene, dtype) -> list:
        return []

    def bath_cutoff(self, scene) -> float | None:
        return None

    def force_range(self, scene, blocks) -> tuple[int, int]:
        return 0, scene.n_particles

    def advance(self, context: StepContext) -> Callable:
        raise NotImplementedError

    def initial_solvent_state(self, scene, dtype):
        return None
