"""Every invalid scene field raises an error naming the field and what is valid."""

import pytest
from conftest import scene_dict

from jaxdpd.scene import Scene
from jaxdpd.solvents import SOLVENTS
from jaxdpd.validation import SceneError, SceneTypeError


class Replace(dict):
    """A section that replaces the base scene's section instead of merging into it."""


INVALID = [
    # (sections to merge, exception, words the message must contain)
    ({"particles": {"density": 0.0, "count": 600}}, ValueError, ["particles.density", "> 0"]),
    ({"particles": {"density": -3.0, "count": 600}}, ValueError, ["particles.density", "> 0"]),
    ({"particles": {"density": 3.0, "count": 1}}, ValueError, ["particles.count", "≥ 2"]),
    ({"particles": {"density": "3", "count": 600}}, TypeError, ["particles.density", "number"]),
    ({"integrator": {"dt": 0.0}}, ValueError, ["integrator.dt", "> 0"]),
    ({"integrator": {"dt": -0.01}}, ValueError, ["integrator.dt", "> 0"]),
    ({"integrator": {"lambda": 1.5}}, ValueError, ["integrator.lambda", "≤ 1"]),
    ({"cutoff": 0.0}, ValueError, ["cutoff", "> 0"]),
    ({"cutoff": -1.0}, ValueError, ["cutoff", "> 0"]),
    ({"particles": {"density": 3.0, "count": 20}}, ValueError, ["box.lengths", "2 (cutoff"]),
    (
        {"box": {"lengths": [10.0, 10.0, 1.9]}, "particles": Replace({"density": 3.0})},
        ValueError,
        ["box.lengths", "L_z"],
    ),
    ({"neighbors": {"skin": 2.5}}, ValueError, ["box.lengths", "neighbors.skin"]),
    ({"pair": {"a": {"solvent-ghost": 25.0}}}, ValueError, ["unknown species", "ghost"]),
    (
        {"particles": {"species": [{"name": "A", "mass": 0.0}]}},
        ValueError,
        ["particles.species[0].mass", "> 0"],
    ),
    (
        {
            "particles": {"species": [{"name": "A", "mass": 2.0}]},
            "solvent": Replace({"method": "hoogerbrugge_koelman"}),
            "pair": None,
            "integrator": None,
        },
        ValueError,
        ["mass", "unit masses"],
    ),
    (
        {
            "pair": {"a": [[25.0, 30.0], [31.0, 25.0]]},
            "particles": {
                "density": 3.0,
                "count": 600,
                "species": [{"name": "A", "fraction": 0.5}, {"name": "B", "fraction": 0.5}],
            },
        },
        ValueError,
        ["pair.a", "symmetric"],
    ),
    (
        {
            "pair": {"a": [[25.0]]},
            "particles": {
                "density": 3.0,
                "count": 600,
                "species": [{"name": "A", "count": 300}, {"name": "B", "count": 300}],
            },
        },
        ValueError,
        ["pair.a", "2×2"],
    ),
    (
        {
            "pair": {"a": {"A-A": 25.0}},
            "particles": {
                "density": 3.0,
                "count": 600,
                "species": [{"name": "A", "count": 300}, {"name": "B", "count": 300}],
            },
        },
        ValueError,
        ["pair.a", "missing", "A-B"],
    ),
    (
        {
            "particles": {
                "density": 3.0,
                "count": 600,
                "species": [{"name": "A", "count": 300}, {"name": "B", "count": 200}],
            }
        },
        ValueError,
        ["particles.species", "sum"],
    ),
    ({"solvent": None}, ValueError, ["solvent", "required"]),
    ({"solvent": Replace({"method": "dpd", "kT": 0.0})}, ValueError, ["solvent.kT", "> 0"]),
    ({"particles": None}, ValueError, ["particles", "required"]),
    ({"pair": Replace({})}, ValueError, ["pair.a", "required"]),
    ({"solvent": {"method": "dpd", "gamma": -1.0}}, ValueError, ["solvent.gamma", "≥ 0"]),
    ({"solvent": {"method": "dpd", "sigma": 2.0}}, ValueError, ["solvent.sigma", "2 γ kT"]),
    ({"solvent": {"method": "lattice"}}, ValueError, ["solvent.method", "valid"]),
    ({"solvent": {"method": "dpd", "noise": "pink"}}, ValueError, ["solvent.noise", "uniform"]),
    ({"precision": "float16"}, ValueError, ["precision", "float32"]),
    ({"seed": -1}, ValueError, ["seed", "≥ 0"]),
    ({"seed": 1.5}, TypeError, ["seed", "integer"]),
    ({"temperature": 1.0}, ValueError, ["unknown key", "temperature"]),
    ({"integrator": {"timestep": 0.01}}, ValueError, ["integrator", "unknown key", "timestep"]),
    ({"neighbors": {"method": "verlet"}}, ValueError, ["neighbors.method", "cell_list"]),
    ({"neighbors": {"format": "dense"}}, ValueError, ["neighbors.format", "jax_md"]),
    ({"run": {"chunk": 0}}, ValueError, ["run.chunk", "≥ 1"]),
    ({"run": {"steps": -5}}, ValueError, ["run.steps", "≥ 0"]),
    ({"output": {"observables": ["viscosity"]}}, ValueError, ["output.observables", "viscosity"]),
    ({"output": {"observables": ["rdf"], "rdf_max": 4.0}}, ValueError, ["output.rdf_max", "half"]),
    ({"output": {"trajectory_every": 75}}, ValueError, ["output.trajectory_every", "run.chunk"]),
]


@pytest.mark.parametrize(("sections", "error", "words"), INVALID)
def test_invalid_field_is_named(sections, error, words):
    data = scene_dict(**{k: v for k, v in sections.items() if not isinstance(v, Replace)})
    data.update({k: dict(v) for k, v in sections.items() if isinstance(v, Replace)})
    with pytest.raises(error) as raised:
        Scene.from_dict(data)
    message = str(raised.value)
    for word in words:
        assert word in message, message


def test_hoogerbrugge_koelman_refuses_a_pair_force_and_dpd_parameters():
    data = scene_dict()
    data["solvent"] = {"method": "hoogerbrugge_koelman"}
    with pytest.raises(ValueError, match=r"pair: .*remove the \[pair\] section"):
        Scene.from_dict(data)
    data["solvent"] = {"method": "hoogerbrugge_koelman", "gamma": 4.5}
    del data["pair"]
    with pytest.raises(ValueError, match=r"solvent: \['gamma'\] belong to method 'dpd'"):
        Scene.from_dict(data)


def test_invalid_toml_names_the_problem(tmp_path):
    path = tmp_path / "broken.toml"
    path.write_text("seed = \n[particles\n")
    with pytest.raises(ValueError, match="not valid TOML"):
        Scene.from_toml(path)


def test_resolved_scene_round_trips_through_to_dict():
    scene = Scene.from_dict(scene_dict())
    assert Scene.from_dict(scene.to_dict()) == scene
    assert scene.n_particles == 600
    assert scene.box.lengths[0] == pytest.approx((600 / 3.0) ** (1 / 3))


@pytest.mark.parametrize(
    ("sections", "error", "field"),
    [
        ({"integrator": {"dt": -0.01}}, SceneError, "integrator.dt"),
        (
            {"particles": {"species": [{"name": "A", "mass": 0.0}]}},
            SceneError,
            "particles.species[0].mass",
        ),
        ({"solvent": {"method": "dpd", "temperature": 1.0}}, SceneError, "solvent"),
        ({"particles": {"density": "3", "count": 600}}, SceneTypeError, "particles.density"),
    ],
)
def test_a_bad_field_raises_scene_error_carrying_its_dotted_path(sections, error, field):
    """The error is a SceneError (a ValueError; for a wrong type also a TypeError)
    whose `field` is the dotted path that its message starts with."""
    with pytest.raises(error) as raised:
        Scene.from_dict(scene_dict(**sections))
    assert raised.value.field == field
    assert str(raised.value).startswith(field)
    assert isinstance(raised.value, ValueError)
    assert isinstance(raised.value, TypeError) == (error is SceneTypeError)


def test_unknown_solvent_method_is_the_registry_scene_error():
    data = scene_dict()
    data["solvent"] = {"method": "lowe_anderson"}
    with pytest.raises(SceneError) as raised:
        Scene.from_dict(data)
    assert raised.value.field == "solvent.method"
    assert "did you mean 'lowe_andersen'?" in str(raised.value)


# The fields without defaults of the methods that have such.
REQUIRED_SOLVENT_FIELDS = {
    "lowe_andersen": {"collision_frequency": 1.0},
    "lattice_boltzmann": {
        "grid_spacing": 1.0,
        "time_step": 0.1,
        "mass_density": 1.0,
        "kinematic_viscosity": 1.0,
        "friction": 1.0,
    },
}


@pytest.mark.parametrize("method", SOLVENTS.names())
def test_a_flow_the_solvent_method_lacks_is_refused_naming_both_fields(method):
    component = SOLVENTS.get(method)
    for kind in sorted({"shear", "planar_elongation"} - set(component.flows)):
        data = scene_dict(flow={"kind": kind})
        data["solvent"] = {"method": method, **REQUIRED_SOLVENT_FIELDS.get(method, {})}
        with pytest.raises(ValueError) as raised:
            Scene.from_dict(data)
        assert f"flow.kind = {kind!r}: solvent.method = {method!r} supports" in str(raised.value)


@pytest.mark.parametrize(
    ("sections", "field"),
    [
        ({"solvent": {"method": "mpcd", "gamma": 1.0}}, "solvent"),
        ({"flow": {"kind": "planar_elongation", "elongation_rate": 0.1}}, "flow.kind"),
        ({"output": {"observables": ["conformation"]}}, "output.observables"),
        (
            {
                "polymers": [
                    {"species": "x", "beads": 2, "bond": {"law": "hookean", "spring_constant": 1}}
                ]
            },
            "polymers[0].species",
        ),
    ],
)
def test_component_checks_raise_scene_errors_naming_the_field(sections, field):
    """Checks owned by components (solvent fields, flows, observables, polymers) reach
    the user as SceneError with the field's dotted path, like the field readers'."""
    data = scene_dict(**sections)
    if "flow" in sections:  # the one solvent without an elongation step
        method = "lattice_boltzmann"
        data["solvent"] = {"method": method, **REQUIRED_SOLVENT_FIELDS[method]}
    with pytest.raises(SceneError) as raised:
        Scene.from_dict(data)
    assert raised.value.field == field
    assert str(raised.value).startswith(field)
