"""The scene-field reference page, generated from the scene schema at build time.

Everything on the page is read from the code a scene is validated by: the field list
of `jaxdpd.scene`'s docstring, the section dataclasses and their defaults, and the
component registries (solvents, pair laws, bond laws, boxes, observables) with each
component's declared fields, capabilities and docstring.  So the page cannot drift
from what `Scene.from_dict` accepts; `docs/hooks.py` renders it into the site.
"""

import dataclasses
import inspect

import jaxdpd.scene as scene_module
from jaxdpd.forces.bonds import BOND_LAWS
from jaxdpd.forces.pair_laws import PAIR_LAWS
from jaxdpd.forces.spring_repulsion import SPRING_REPULSION_LAWS
from jaxdpd.geometry.boxes import BOXES
from jaxdpd.observables import OBSERVABLES
from jaxdpd.scene import Scene
from jaxdpd.solvents import SOLVENTS

# Sections whose dataclass defaults are the scene's defaults (the others have no
# section-wide defaults: their fields depend on a kind or are required).
DEFAULTED_SECTIONS = {
    "neighbors": scene_module.Neighbors,
    "parallel": scene_module.Parallel,
    "run": scene_module.Run,
    "output": scene_module.Output,
    "flow": scene_module.Flow,
}


def _first_paragraph(obj) -> str:
    doc = inspect.getdoc(obj) or ""
    return " ".join(doc.split("\n\n")[0].split())


def _cell(text) -> str:
    return str(text).replace("|", "\\|").replace("\n", " ")


def _value(value) -> str:
    if value is dataclasses.MISSING:
        return "required"
    if callable(value):
        return "computed"
    return f"`{value!r}`"


def schema_sections() -> list[tuple[str, str]]:
    """(section, description) from the field list in `jaxdpd.scene`'s docstring."""
    doc = inspect.getdoc(scene_module)
    lines = doc.split("Sections and fields", 1)[1].split("\n")[2:]
    entries = []
    for line in lines:
        if not line.strip():
            continue
        if line.startswith("    ") and not line.startswith("     "):
            name, _, rest = line.strip().partition(" ")
            entries.append([name, rest.strip()])
        elif entries:
            entries[-1][1] += " " + line.strip()
    return [(name, " ".join(text.split())) for name, text in entries]


def _table(header: tuple[str, ...], rows) -> list[str]:
    out = ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
    out += ["| " + " | ".join(_cell(c) for c in row) + " |" for row in rows]
    return out + [""]


def solvent_default(method, section: dict, name: str) -> str:
    """A solvent field's default as the method's own reader gives it: read the example
    section without the field ("required" when the reader refuses that), then once more
    with every other number scaled, to tell a fixed default from one derived from the
    other fields."""
    trimmed = {key: value for key, value in section.items() if key != name}
    try:
        resolved = method.to_dict(method.read(trimmed))
    except (ValueError, TypeError):
        return "required"
    if name not in resolved:
        return "optional (see the description)"
    scaled = {
        key: value * 1.25 if isinstance(value, float) else value for key, value in trimmed.items()
    }
    try:
        fixed = method.to_dict(method.read(scaled)).get(name) == resolved[name]
    except (ValueError, TypeError):
        fixed = False
    return _value(resolved[name]) if fixed else "derived from other fields (see the description)"


def solvent_section(method) -> list[str]:
    section = method.example_scene("float32")["solvent"]
    parameters = Scene.from_dict(method.example_scene("float32")).solvent
    own = ("kT",) if method.sets_temperature else ()  # solvent.kT: a set temperature
    rows = [
        (f"`{name}`", solvent_default(method, section, name)) for name in (*own, *method.fields)
    ]
    lambda_note = "yes" if method.integrator_lambda else "no"
    unavailable = ", ".join(f"`{k}` ({v})" for k, v in method.unavailable_observables.items())
    out = [f"### `{method.name}`", "", _first_paragraph(type(method)), ""]
    out += _table(("field", "default"), rows)
    out += [
        f"- flows: {', '.join(f'`{f}`' for f in method.flows) or 'none'}",
        f"- `[pair]` forces: {'yes' if method.pair_forces else 'no'}; "
        f"`[body_force]`: {'yes' if method.body_forces else 'no'}; "
        f"`integrator.lambda`: {lambda_note}",
        f"- default `integrator.dt`: {method.default_dt(parameters)!r}; "
        f"sets the temperature: {'yes' if method.sets_temperature else 'no (kT starts it)'}",
    ]
    if unavailable:
        out.append(f"- observables it cannot provide: {unavailable}")
    module = type(method).__module__
    return out + [f"- module: `{module}`", ""]


def render() -> str:
    out = [
        "# Scene reference",
        "",
        "Generated when the site is built, from the code that validates a scene "
        "(`jaxdpd.scene` and the component registries), so it lists exactly what "
        "`Scene.from_dict` accepts. Reduced units: r_c = m = k_BT = 1 "
        "([conventions](conventions.md)). An unknown or misplaced field is refused "
        "with a `SceneError` naming it.",
        "",
        "## Sections",
        "",
    ]
    out += _table(("section / field", "values"), [(f"`{n}`", t) for n, t in schema_sections()])
    out += ["## Section defaults", ""]
    for section, cls in DEFAULTED_SECTIONS.items():
        rows = [
            (f"`{f.name.rstrip('_')}`", _value(f.default))
            for f in dataclasses.fields(cls)
            if f.name not in ("kind", "settings")
        ]
        out += [f"**[{section}]**", ""] + _table(("field", "default"), rows)
    out += ["## Solvent methods (`solvent.method`)", ""]
    for method in SOLVENTS:
        out += solvent_section(method)
    out += ["## Pair laws (`pair.kind`)", ""]
    out += _table(
        ("kind", "fields", "law"),
        [
            (f"`{p.name}`", ", ".join(f"`{f}`" for f in p.fields), _first_paragraph(type(p)))
            for p in PAIR_LAWS
        ],
    )
    out += ["## Bond laws (`polymers[].bond.law`)", ""]
    bond_rows = []
    for law in BOND_LAWS:
        fields = ", ".join(
            f"`{name}`"
            + (
                ""
                if isinstance(p.default, object) and type(p.default) is object
                else f" = {p.default!r}"
            )
            for name, p in law.parameters.items()
        )
        bond_rows.append((f"`{law.name}`", fields, _first_paragraph(type(law))))
    out += _table(("law", "parameters (= default)", "law"), bond_rows)
    out += ["## Boxes (`box.kind`)", ""]
    out += _table(
        ("kind", "for flow", "box"),
        [
            (f"`{b.name}`", f"`{b.flow_kind}`" if b.flow_kind else "none", _first_paragraph(b))
            for b in BOXES
        ],
    )
    out += [
        "## Other kinds",
        "",
        f"- `body_force.kind`: {', '.join(f'`{k}`' for k in scene_module.BODY_FORCE_KINDS)}",
        f"- `spring_repulsion.law`: {', '.join(f'`{k}`' for k in SPRING_REPULSION_LAWS)}",
        f"- `neighbors.method`: {', '.join(f'`{k}`' for k in scene_module.NEIGHBOR_METHODS)};"
        f" `neighbors.format`: {', '.join(f'`{k}`' for k in scene_module.JAX_MD_FORMATS)}",
        f"- `precision`: {', '.join(f'`{k}`' for k in scene_module.PRECISIONS)}",
        "",
        "## Observables (`output.observables`)",
        "",
    ]
    rows = []
    for observable in OBSERVABLES:
        settings = ", ".join(
            f"`output.{s.name}` = {_value(s.default)}" for s in observable.settings
        )
        units = observable.units if isinstance(observable.units, dict) else {}
        unit_text = ", ".join(f"`{k}` [{v}]" for k, v in units.items())
        rows.append(
            (
                f"`{observable.name}`",
                _first_paragraph(type(observable)),
                settings or "—",
                unit_text or "—",
            )
        )
    out += _table(("name", "what", "settings", "series [unit]"), rows)
    return "\n".join(out)
