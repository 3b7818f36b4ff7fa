"""Registries of named components: solvents, observables, bond laws, pair laws, boxes.

A component is an object with a `name` (the value a scene file uses to pick it) that
owns everything about itself: its scene fields, its checks, its capabilities and the
functions it contributes to the step.  `build` looks components up here by the
names a scene gives and never names one itself, so a new component is one module
plus one `register` call (see docs/extending.md).
"""

import difflib
from collections.abc import Iterator
from typing import Generic, TypeVar

from jaxdpd.validation import SceneError

Component = TypeVar("Component")


class Registry(Generic[Component]):
    """The components of one kind, by name, in registration order.

    Args:
        kind: what the components are, for messages ("solvent method").
        field: the scene field that names one ("solvent.method").
    """

    def __init__(self, kind: str, field: str):
        self.kind = kind
        self.field = field
        self._components: dict[str, Component] = {}

    def register(self, component: Component) -> Component:
        """Add `component` under `component.name`; returns it (usable as a decorator)."""
        name = component.name
        if name in self._components:
            raise ValueError(f"{self.kind} {name!r} is already registered")
        self._components[name] = component
        return component

    def unregister(self, name: str) -> None:
        """Remove a component (for tests that register toy components)."""
        del self._components[name]

    def get(self, name: str) -> Component:
        """The component called `name`, or a SceneError naming the field, the valid
        names and the closest one."""
        try:
            return self._components[name]
        except (KeyError, TypeError):
            raise SceneError(self.field, unknown_name_message(name, self.names())) from None

    def names(self) -> tuple[str, ...]:
        return tuple(self._components)

    def __iter__(self) -> Iterator[Component]:
        return iter(tuple(self._components.values()))

    def __contains__(self, name) -> bool:
        return name in self._components


def unknown_name_message(name, valid) -> str:
    """`'x': valid values are [...]` with a did-you-mean suggestion when one is close."""
    message = f"{name!r}: valid values are {list(valid)}"
    close = difflib.get_close_matches(str(name), list(valid), n=1)
    if close:
        message += f" (did you mean {close[0]!r}?)"
    return message
