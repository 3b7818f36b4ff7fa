"""Traced model parameters: values a compiled step reads from the state.

A scene's numbers are normally constants of the compiled step.  Those listed here
are instead kept in `SimState.parameters` and read by their force kernel at every
step, so that changing them needs no recompilation, an ensemble may give every
replica its own values (`jax.vmap` over states), and a derivative with respect to
them can be taken.  The pytree is a nested dict, one entry per term of the scene:

    {"bond": {<species>: {<parameter of its law>: scalar, ...}, ...},
     "body_force": {"amplitude": scalar}}

("bond" for scenes with [[polymers]], parameters as in the scene's bond table, e.g.
spring_constant and max_extension of a FENE law; "body_force" for scenes with a
[body_force]).  Another term joins the same way: `scene_parameters` gives its
initial values from the scene, and its kernel reads `state.parameters[<term>]`.

Scene validation (e.g. a spring shorter than half the box) applies to the scene's
values only; values set later are checked at run time by the error flags (an
overstretched or too long spring stops the run).
"""

import jax.numpy as jnp


def scene_parameters(scene, blocks, dtype) -> dict:
    """The initial parameter pytree of a scene (see the module docstring).

    Args:
        scene: the Scene.
        blocks: its chain blocks (jaxdpd.geometry.chain_topology.chain_blocks).
        dtype: floating dtype of the simulation.
    Returns:
        dict of scalar arrays of `dtype`; empty when the scene has no such terms.
    """
    parameters = {}
    if blocks:
        parameters["bond"] = {
            block.species: {
                name: jnp.asarray(value, dtype) for name, value in block.law.parameters.items()
            }
            for block in blocks
        }
    if scene.body_force is not None:
        parameters["body_force"] = {"amplitude": jnp.asarray(scene.body_force.amplitude, dtype)}
    return parameters


def with_parameters(state, updates: dict):
    """The state with some traced parameters replaced.

    Args:
        state: a SimState (single replica) whose `parameters` came from
            `scene_parameters`.
        updates: a nested dict with the same keys as (part of) `state.parameters`,
            e.g. {"bond": {"dumbbell": {"spring_constant": 2.0}}}; values are
            Python numbers (taken at the simulation's precision) or scalar arrays of
            the simulation's dtype.
    Returns:
        The updated state.
    Raises:
        ValueError: an unknown key (naming the path and the valid keys) or a value
            that is not a finite scalar.
        TypeError: an array of another floating dtype (no silent down- or up-cast).
    """
    return state.set(parameters=_merge(state.parameters or {}, updates, "parameters"))


def _merge(current: dict, updates: dict, path: str) -> dict:
    if not isinstance(updates, dict):
        raise TypeError(f"{path}: expected a dict, got {type(updates).__name__}")
    merged = dict(current)
    for key, value in updates.items():
        if key not in current:
            raise ValueError(
                f"{path}.{key}: not a traced parameter of this simulation; valid keys: "
                f"{sorted(current)}"
            )
        if isinstance(current[key], dict):
            merged[key] = _merge(current[key], value, f"{path}.{key}")
        else:
            merged[key] = _scalar(value, current[key], f"{path}.{key}")
    return merged


def _scalar(value, like, path: str):
    number = isinstance(value, (int, float)) and not isinstance(value, bool)
    if not number and not hasattr(value, "dtype"):
        raise TypeError(f"{path}: expected a number, got {type(value).__name__} {value!r}")
    if not number:  # an array (NumPy float64 scalars are Python floats, taken as numbers)
        if jnp.ndim(value) != 0:
            raise ValueError(f"{path}: expected a scalar, got shape {jnp.shape(value)}")
        if jnp.issubdtype(value.dtype, jnp.floating) and value.dtype != like.dtype:
            raise TypeError(
                f"{path}: value of dtype {value.dtype} for a {like.dtype} simulation; "
                f"convert it explicitly (e.g. jnp.asarray(x, '{like.dtype}'))"
            )
    array = jnp.asarray(value, like.dtype)
    if not bool(jnp.isfinite(array)):
        raise ValueError(f"{path} = {value!r}: must be finite")
    return array
