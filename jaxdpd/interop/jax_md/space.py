"""A jaxdpd box as a jax-md space: `(displacement_fn, shift_fn)`.

jax-md's spaces take the box geometry per call as the keyword `box=` (and `new_box=`
in `shift_fn`, for a box that changes during the step); here `box=` is the jaxdpd
box *state* (`LeesEdwardsState`: offset and clock; `KraynikReineltState`: strain
modulo the period), which `box.advance` moves on.  The state stays bounded, so the
geometry is as exact in float32 after 10⁶ strain units as at the start, where
jax-md's `periodic_general` would have to carry an ever-growing tilt.

Minimum image is the box's own (`minimum_image_vectors`): thesis eq. 3.19 in a
Lees–Edwards box, rounding in the Gauss-reduced basis in a Kraynik–Reinelt box.  It
is exact for separations shorter than half the thinnest cell height over the box's
whole history (`box.cell_heights`), which covers every pair within a cut-off below
that: the criterion that jax-md's `periodic_general` lacks (jax-md issue 200).
"""

import jax.numpy as jnp
from jax_md import space as jmd_space


def has_state(box) -> bool:
    """Whether the box changes with time (Lees–Edwards, Kraynik–Reinelt): its
    functions then need the box state per call."""
    return box.initial_state(jnp.float32) is not None


def require_state(box, state, where: str):
    """Raise a TypeError naming `where` if a flowing box was given no state."""
    if state is None and has_state(box):
        raise TypeError(
            f"{where}: a {box.name!r} box needs its state on every call "
            "(box.initial_state(dtype), moved on by box.advance); got None"
        )


def space(box):
    """`(displacement_fn, shift_fn)` of a jaxdpd box with jax-md's conventions.

        displacement_fn(Ra, Rb, box=state, perturbation=None, **unused) -> Ra − Rb
        shift_fn(R, dR, box=state, new_box=None, **unused) -> R + dR, wrapped

    Positions and separations have shape (..., 3); `perturbation` (3, 3) deforms the
    separations as in jax-md (`jax_md.quantity.stress`).  `shift_fn` wraps into the
    primary cell of `new_box` when given (the box after the step), else of `box`.

    A flowing box's displacement called without `box=` returns NaN: jax-md calls it
    so once, to learn its output shape (`space.canonicalize_displacement_or_metric`),
    and a forgotten state then shows at once in the forces instead of silently
    measuring the box at zero strain.

    Args:
        box: a jaxdpd box (`jaxdpd.geometry.boxes.make_box` or a class of `BOXES`).
    Raises:
        TypeError: (at trace time) `shift_fn` of a flowing box without a box state.
    """
    static_box = box  # the keyword `box=` below is the state, as in jax-md
    stateful = has_state(static_box)

    def displacement_fn(Ra, Rb, box=None, perturbation=None, **unused_kwargs):
        if stateful and box is None:
            return jnp.full(jnp.shape(Ra - Rb), jnp.nan, jnp.result_type(Ra, Rb))
        separation = static_box.bind(box).minimum_image_vectors(Ra - Rb)
        if perturbation is not None:
            separation = jmd_space.raw_transform(perturbation, separation)
        return separation

    def shift_fn(R, dR, box=None, new_box=None, **unused_kwargs):
        state = box if new_box is None else new_box
        require_state(static_box, state, "shift_fn(R, dR, box=)")
        target = static_box.bind(state)
        moved = jnp.reshape(R + dR, (-1, 3))
        wrapped, _ = target.wrap(moved, jnp.zeros(moved.shape, jnp.int32))
        return jnp.reshape(wrapped, jnp.shape(R))

    return displacement_fn, shift_fn
