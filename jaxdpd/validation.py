"""Checks that turn bad scene input into errors naming the field and what is valid.

Each reader takes the section dictionary, the key and the dotted path of the
section, and raises, before anything is traced, a `SceneError` (a `ValueError`) for
a value out of range or a missing or unknown key, and a `SceneTypeError` (both a
`SceneError` and a `TypeError`) for a value of the wrong type.
"""

import difflib
import math
import re

_MISSING = object()


class SceneError(ValueError):
    """Bad scene input: `field` is the dotted path of the offending field
    ("solvent.kT", "polymers[0].bond.law"); the message starts with it, followed by
    the offending value when one is given ("solvent.kT = -1.0: must be > 0")."""

    def __init__(self, field: str, message: str, value=_MISSING):
        self.field = field
        subject = field if value is _MISSING else f"{field} = {value!r}"
        super().__init__(f"{subject}: {message}" if message else subject)


class SceneTypeError(SceneError, TypeError):
    """A scene field holds a value of the wrong type (a table where a number belongs)."""


# The field path a scene message starts with: "polymers[0].bond.law", "output".
_LEADING_FIELD = re.compile(
    r"([A-Za-z_]\w*(?:\[\d+\])?(?:\.[A-Za-z_]\w*(?:\[\d+\])?)*)(?=:| =| has )"
)


def as_scene_error(error: Exception) -> Exception:
    """`error` (a ValueError or TypeError raised while reading a scene, whose message
    starts with the field it is about, as every scene check's does) as the matching
    SceneError carrying that field; unchanged when it names no field."""
    match = _LEADING_FIELD.match(str(error))
    if isinstance(error, SceneError) or match is None:
        return error
    kind = SceneTypeError if isinstance(error, TypeError) else SceneError
    converted = kind(match.group(1), "")
    converted.args = error.args
    return converted


INT32_MAX = 2**31 - 1
# Pass as `default` to make a field required (the readers' default).
REQUIRED = _MISSING


def check_keys(section: dict, allowed, path: str) -> None:
    """Refuse keys that the section does not know."""
    if not isinstance(section, dict):
        raise SceneTypeError(path, f"expected a table (dict), got {type(section).__name__}")
    for key in section:
        if not isinstance(key, str):
            raise SceneTypeError(path, f"keys must be strings, got {key!r}")
    unknown = sorted(set(section) - set(allowed))
    if unknown:
        raise SceneError(path, unknown_keys_message(unknown, allowed))


def unknown_keys_message(unknown, allowed) -> str:
    """The error for unknown keys: each with its closest valid key (difflib), e.g.
    "unknown key(s) 'gama' (did you mean 'gamma'?)"; the valid keys follow only when
    some unknown key resembles none of them."""
    valid = sorted(set(allowed))
    guesses = {key: difflib.get_close_matches(key, valid, n=1) for key in unknown}
    named = ", ".join(
        repr(key) + (f" (did you mean {guess[0]!r}?)" if guess else "")
        for key, guess in guesses.items()
    )
    if all(guesses.values()):
        return f"unknown key(s) {named}"
    return f"unknown key(s) {named}; valid keys: {valid}"


def _field(path: str, key: str) -> str:
    return f"{path}.{key}" if path else key


def _present(section: dict, key: str, path: str, default, hint: str = "") -> bool:
    """True when `key` is given; False when absent with a default; else an error."""
    if key in section:
        return True
    if default is _MISSING:
        raise SceneError(_field(path, key), f"required field is missing{hint}")
    return False


def read_number(
    section: dict,
    key: str,
    path: str,
    default=_MISSING,
    *,
    minimum=None,
    maximum=None,
    exclusive_minimum=False,
    integer=False,
):
    """A real (or integer) field within [minimum, maximum] (minimum exclusive on request).

    An integer field without a `maximum` is bounded by INT32_MAX: counts, sizes and
    step numbers enter int32 arithmetic on the device (jaxdpd.run.resources).
    """
    name = _field(path, key)
    if not _present(section, key, path, default):
        return default
    value = section[key]
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        kind = "an integer" if integer else "a number"
        raise SceneTypeError(name, f"expected {kind}, got {type(value).__name__} {value!r}")
    if integer and not isinstance(value, int):
        raise SceneTypeError(name, f"expected an integer, got {value!r}")
    if isinstance(value, int) and not -(2**63) <= value < 2**63:
        raise SceneError(name, "must lie within the 64-bit integer range (as in TOML)")
    if not math.isfinite(value):
        raise SceneError(name, f"must be finite, got {value!r}")
    if minimum is not None:
        if exclusive_minimum and not value > minimum:
            raise SceneError(name, f"must be > {minimum}", value)
        if not exclusive_minimum and not value >= minimum:
            raise SceneError(name, f"must be ≥ {minimum}", value)
    if integer and maximum is None:
        maximum = INT32_MAX
    if maximum is not None and not value <= maximum:
        raise SceneError(name, f"must be ≤ {maximum}", value)
    return int(value) if integer else float(value)


def read_choice(section: dict, key: str, path: str, choices, default=_MISSING):
    """A string field taking one of `choices`."""
    name = _field(path, key)
    if not _present(section, key, path, default, f"; valid: {list(choices)}"):
        return default
    value = section[key]
    if not isinstance(value, str):
        raise SceneTypeError(name, f"expected a string, got {type(value).__name__} {value!r}")
    if value not in choices:
        raise SceneError(name, f"valid values are {list(choices)}", value)
    return value


def read_string(section: dict, key: str, path: str, default=_MISSING):
    """A free string field."""
    name = _field(path, key)
    if not _present(section, key, path, default):
        return default
    value = section[key]
    if not isinstance(value, str) or not value:
        raise SceneTypeError(name, f"expected a non-empty string, got {value!r}")
    return value


def read_list(section: dict, key: str, path: str, default=_MISSING):
    """A list field (element checks are the caller's)."""
    name = _field(path, key)
    if not _present(section, key, path, default):
        return default
    value = section[key]
    if not isinstance(value, (list, tuple)):
        raise SceneTypeError(name, f"expected a list, got {type(value).__name__} {value!r}")
    return list(value)
