"""Frozen dataclasses that are JAX pytrees: the state containers of the engine.

`@dataclass` makes a frozen dataclass, registers it with
`jax.tree_util.register_dataclass` (fields are leaves unless made with
`static_field()`, which are part of the tree's structure) and gives it
`set(**changes)`, a copy with fields replaced.  This is the interface of
`jax_md.dataclasses`, kept here so that importing jaxdpd does not import all of
jax-md, whose import runs over a hundred small XLA compilations (its rigid-body
module builds shapes at import time).
"""

import dataclasses

import jax


def dataclass(cls):
    """`cls` as a frozen dataclass registered as a pytree, with `.set(**changes)`."""
    registered = jax.tree_util.register_dataclass(dataclasses.dataclass(frozen=True)(cls))
    registered.set = lambda self, **changes: dataclasses.replace(self, **changes)
    return registered


def static_field(**field_kwargs):
    """A field that belongs to the tree's structure, not its leaves (hashable)."""
    return dataclasses.field(metadata={"static": True}, **field_kwargs)
