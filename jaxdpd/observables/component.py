"""The observable component protocol: what one observable owns, in one module.

An observable is registered in `jaxdpd.observables.OBSERVABLES` under the name a scene
lists in `output.observables`.  It owns, as attributes and methods of one object:

    name             the value in output.observables ("pressure")
    settings         the [output] fields it owns (`Setting`: name, default, range);
                     every registered observable's settings are read and resolved in
                     every scene (Scene.to_dict lists them all), and read back as
                     attributes of the scene's Output (`scene.output.rdf_bins`)
    needs_polymers   refused without [[polymers]] (message names the field)
    needs_virial     the step records the virial parts (SimState.virial) for it
    consumes         raw per-step sample names it turns into series on the host
                     (`reduce`); other samples pass through to the series unchanged
    check(scene)     cross-section checks of a resolved scene, raising a SceneError
                     naming the field
    sampler(context) the per-step sampler, `sample(previous, state) -> (state,
                     samples)`, traced inside the scan after the solvent's step, or
                     None (e.g. g(r), measured at chunk ends on the host)
    decomposes       it is measured in decomposed runs (jaxdpd.decomposition), by
                     `domain_sampler(context)`: `sample(ownership, state) ->
                     samples` over one device's rows (owned, halo copies and free
                     rows; `ownership` says which are owned and which particle each
                     holds), summed over the devices, or None (no per-step sample)
    accumulates      it keeps on-device accumulators in SimState.observers (at most
                     one observable of a scene does), made by
                     `initial_accumulators(context, bound_box, positions, image)`
    reduce(samples, scene)   host side, per chunk: the series it makes from the raw
                     samples it consumes
    chunk_accumulator(simulation)   a host-side accumulator sampled at production
                     chunk ends (g(r)), or None: `observe(state)`, `extras()` (arrays
                     stored with a checkpoint) and `restore(extras)`, `write(writer)`
                     (its averages into the H5MD file at the end) and `result()`
    units            series leaf name -> reduced unit of its H5MD elements
    memory(scene, itemsize)   {field: bytes} of its arrays, for the resource check
    summary_rows(scene, series, n_blocks)   name -> (mean, standard error) rows of
                     the run summary (jaxdpd.analysis.rheology.summary_rows)
    example_scene(precision)   a small valid scene dict that records it (by default a
                     DPD chain solution, `example_fluid`); the contract tests
                     (tests/test_observable_contracts.py) run every registered
                     observable through it

`Observable` gives the defaults (no settings, nothing needed, no sampler, no
reduction, no rows); a component overrides what it has.  `build` and the driver loop
over the scene's observables in registration order and name none of them.
"""

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from jaxdpd.scene_examples import chain_solution_example
from jaxdpd.validation import read_number


@dataclass(frozen=True)
class Setting:
    """One [output] field an observable owns: a number with a default and a range.

    Attributes:
        name: the key in [output] ("rdf_bins").
        default: its value when absent, or `default(cutoff)` of the scene's r_c.
        minimum, maximum, exclusive_minimum, integer: the range, as
            jaxdpd.validation.read_number takes it.
    """

    name: str
    default: object
    minimum: float | None = None
    maximum: float | None = None
    exclusive_minimum: bool = False
    integer: bool = False

    def read(self, section: dict, cutoff: float):
        """The field's value from the [output] table `section`."""
        default = self.default(cutoff) if callable(self.default) else self.default
        return read_number(
            section,
            self.name,
            "output",
            default,
            minimum=self.minimum,
            maximum=self.maximum,
            exclusive_minimum=self.exclusive_minimum,
            integer=self.integer,
        )


@dataclass(frozen=True)
class BuildContext:
    """What a sampler may read of the built simulation (jaxdpd.engine.build).

    Attributes:
        scene: the scene.
        box: the static box (bind it to a state's box_state).
        blocks: the polymer chain blocks (jaxdpd.geometry.chain_topology.ChainBlock).
        masses: (N,) particle masses, or None when all are 1.
        dtype: floating dtype of positions and velocities.
        spring_search: the spring-pair list's builder, or None.
    """

    scene: object
    box: object
    blocks: tuple
    masses: object
    dtype: object
    spring_search: object


class Observable:
    """Base of the observable components: the defaults of the protocol (see the
    module docstring)."""

    name: str = ""
    settings: tuple[Setting, ...] = ()
    needs_polymers: bool = False
    needs_virial: bool = False
    consumes: tuple[str, ...] = ()
    accumulates: bool = False
    decomposes: bool = False
    units: dict = {}

    def check(self, scene) -> None:
        """Cross-section checks of the resolved `scene` (none by default)."""

    def sampler(self, context: BuildContext) -> Callable | None:
        """`sample(previous, state) -> (state, samples)`, or None."""
        return None

    def domain_sampler(self, context: BuildContext) -> Callable:
        """In a decomposed run (jaxdpd.decomposition; only when `decomposes`),
        `sample(ownership, state) -> samples` from one device's stepped rows, summed
        over the devices with `ownership` (jaxdpd.engine.ownership), or None."""
        raise NotImplementedError(f"observable {self.name!r} is not measured in decomposed runs")

    def initial_accumulators(self, context: BuildContext, bound_box, positions, image):
        """Empty on-device accumulators for one replica (only when `accumulates`)."""
        raise NotImplementedError(f"observable {self.name!r} keeps no accumulators")

    def chunk_accumulator(self, simulation):
        """A host-side accumulator sampled at chunk ends (module docstring), or None."""
        return None

    def reduce(self, samples: dict, scene) -> dict:
        """Series made from the consumed raw samples (host side, NumPy)."""
        return {}

    def memory(self, scene, itemsize: int) -> dict:
        """{field: bytes} of the arrays it holds beyond one value per step and chunk
        (jaxdpd.run.resources: lower bounds checked before a build allocates)."""
        return {}

    def summary_rows(self, scene, series: dict, n_blocks: int) -> dict:
        """Rows of the run summary: name -> (mean, standard error) as Python floats,
        from `series` (per-step samples or block means; see `long_enough`)."""
        return {}

    def example_scene(self, precision: str = "float64") -> dict:
        """A small valid scene (a few hundred particles) that records this observable;
        a component whose `check` needs more (a body force, a setting) adds it."""
        return example_fluid(precision, [self.name])


def example_fluid(precision: str, observables: list) -> dict:
    """The particle solvents' chain solution (jaxdpd.scene_examples) in Groot–Warren
    DPD, with Hookean springs H = 10 (short enough for the spring-pair list's
    half-box limit), recording `observables` for 10 steps."""
    return chain_solution_example(
        precision,
        {"method": "dpd", "kT": 1.0, "gamma": 4.5},
        10.0,
        pair={"a": 25.0},
        integrator={"dt": 0.04, "lambda": 0.65},
        run={"steps": 10, "chunk": 5},
        output={"observables": list(observables)},
    )


def long_enough(series: dict, name: str, n_blocks: int) -> bool:
    """Whether `series` holds `name` with at least `n_blocks` (≥ 2) samples: shorter
    series give no summary row."""
    return n_blocks >= 2 and name in series and np.shape(series[name])[0] >= n_blocks


def steady_shear_rate(scene) -> float | None:
    """γ̇ of a steady, nonzero shear flow (material functions exist), else None."""
    flow = scene.flow
    if flow is None or flow.kind != "shear" or flow.oscillation_frequency is not None:
        return None
    return flow.shear_rate or None


def steady_elongation_rate(scene) -> float | None:
    """ε̇ of a nonzero planar elongational flow (elongational viscosities exist), else
    None."""
    flow = scene.flow
    if flow is None or flow.kind != "planar_elongation":
        return None
    return flow.elongation_rate or None


def summary_row(estimate) -> tuple[float, float]:
    """(mean, standard error) as Python floats."""
    mean, error = estimate
    return float(mean), float(error)
