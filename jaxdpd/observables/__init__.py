"""Observables: per-step samples inside the scan, chunk-end samples outside it.

`OBSERVABLES` holds the observable components (jaxdpd.observables.component) by the
name `output.observables` lists, in the order a step samples them and a chunk's
series are made.  A new observable is one module plus one `register` line here.
"""

import jax
import jax.numpy as jnp

from jaxdpd.observables.chain_correlators import Dynamics
from jaxdpd.observables.chain_series import Conformation
from jaxdpd.observables.component import Observable
from jaxdpd.observables.drag import Drag
from jaxdpd.observables.profiles import Profile
from jaxdpd.observables.rdf import Rdf
from jaxdpd.observables.spring_pairs import SpringPairs
from jaxdpd.observables.thermo import Pressure, Temperature
from jaxdpd.observables.transverse_current import TransverseCurrent
from jaxdpd.registry import Registry

OBSERVABLES: Registry[Observable] = Registry("observable", "output.observables")
OBSERVABLES.register(Temperature())
OBSERVABLES.register(Pressure())
OBSERVABLES.register(Rdf())
OBSERVABLES.register(Conformation())
OBSERVABLES.register(Drag())
OBSERVABLES.register(Profile())
OBSERVABLES.register(TransverseCurrent())
OBSERVABLES.register(Dynamics())
OBSERVABLES.register(SpringPairs())


def scene_observables(scene) -> list[Observable]:
    """The components of the scene's output.observables, in registration order."""
    return [component for component in OBSERVABLES if component.name in scene.output.observables]


def reduce_samples(samples: dict, scene) -> dict:
    """One chunk's per-step samples → named time series (NumPy, host side).

    Samples that no registered observable consumes (already named series, e.g.
    conformation) pass through first, in their order; then every observable whose
    consumed raw samples are all present adds its series (the kinetic tensor gives
    "temperature" whenever it was sampled).
    """
    consumed = {name for component in OBSERVABLES for name in component.consumes}
    series = {name: values for name, values in samples.items() if name not in consumed}
    for component in OBSERVABLES:
        if component.consumes and all(name in samples for name in component.consumes):
            series.update(component.reduce(samples, scene))
    return series


def summary_rows(scene, series: dict, n_blocks: int = 20) -> dict:
    """Rows for the run summary: name -> (mean, standard error) as Python floats, from
    every registered observable whose series are present.

    Args:
        scene: the run's scene.
        series: name → (T, ...) series, per-step samples or the block means of a
            streamed run (jaxdpd.analysis.running_averages.RunningBlockAverages.block_means,
            T = n_blocks: every row is linear in the samples or a ratio of such means,
            so block means give the same estimates).
        n_blocks: blocks of the time series (≥ 2); shorter series give no row.
    """
    rows = {}
    for component in OBSERVABLES:
        rows.update(component.summary_rows(scene, series, n_blocks))
    return rows


def initial_observers(components, context, state):
    """`state` with empty on-device accumulators of the accumulating component among
    `components` (at most one per scene; jaxdpd.scene checks), e.g. to discard the
    equilibration.

    `state` is one replica (positions (N, 3)) or a batch (B, N, 3) from
    jaxdpd.run.ensemble; a batch gets B copies of one replica's empty accumulators
    (they depend only on the shapes), stacked on a leading axis.
    """
    accumulating = [component for component in components if component.accumulates]
    if not accumulating:
        return state
    batch_shape = state.positions.shape[:-2]
    if len(batch_shape) > 1:
        raise ValueError(
            f"init_observers: state.positions must be (N, 3) or (B, N, 3), "
            f"got shape {state.positions.shape}"
        )
    positions, image, box_state = state.positions, state.image, state.box_state
    if batch_shape:
        positions, image = positions[0], image[0]
        box_state = jax.tree.map(lambda leaf: leaf[0], box_state)
    (component,) = accumulating
    bound_box = context.box.bind(box_state)
    observers = component.initial_accumulators(context, bound_box, positions, image)
    return state.set(
        observers=jax.tree.map(
            lambda leaf: jnp.broadcast_to(leaf, batch_shape + leaf.shape), observers
        )
    )
