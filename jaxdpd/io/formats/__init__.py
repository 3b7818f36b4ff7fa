"""Configuration files of other codes: GSD, extended XYZ, LAMMPS data.

Each format is a module with `name`, `extensions`, `multi_frame` (False: one
configuration per file), `write(path, configurations, **options)` (`write_options`
names those options) and `read(path, frame) -> Configuration`
(jaxdpd.io.formats.configuration); FILE_FORMATS registers them by name.  Export of
a run: jaxdpd.io.export; a run started from such a file: jaxdpd.io.initial.
"""

from pathlib import Path

from jaxdpd.io.formats import gsd, lammps_data, xyz
from jaxdpd.io.formats.configuration import Configuration
from jaxdpd.registry import Registry, unknown_name_message
from jaxdpd.validation import SceneError

FILE_FORMATS = Registry("configuration file format", "initial.format")
for _module in (gsd, xyz, lammps_data):
    FILE_FORMATS.register(_module)


def format_of(path, name: str | None = None, field: str = "initial.format"):
    """The format module called `name`, or (None) the one `path`'s extension names.

    Raises:
        ValueError: neither names a format (the message starts with `field`).
    """
    if name is not None:
        try:
            return FILE_FORMATS.get(name)
        except SceneError:  # the registry names initial.format; say which field erred
            raise SceneError(field, unknown_name_message(name, FILE_FORMATS.names())) from None
    suffix = Path(path).suffix.lower()
    for module in FILE_FORMATS:
        if suffix in module.extensions:
            return module
    known = {module.name: list(module.extensions) for module in FILE_FORMATS}
    raise ValueError(
        f"{field}: the format of {str(path)!r} does not follow from its extension "
        f"{suffix!r}; give it ({known})"
    )


__all__ = ["FILE_FORMATS", "Configuration", "format_of"]
