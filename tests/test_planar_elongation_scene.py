"""Scene fields of planar elongation: validation with errors that name the field,
the round trip through `to_dict`, the box factory and per-replica flow rates (no
simulation is compiled here)."""

import jax.numpy as jnp
import numpy as np
import pytest
from conftest import scene_dict

from jaxdpd.geometry import flows
from jaxdpd.geometry.boxes import KraynikReineltBox, make_box
from jaxdpd.run import ensemble
from jaxdpd.scene import Scene

FLOW = {"kind": "planar_elongation", "elongation_rate": 0.2}


def elongation_dict(lengths=(6.0, 4.0, 6.0), **sections):
    data = scene_dict(box={"lengths": list(lengths)}, flow=FLOW, **sections)
    data["particles"] = {"density": 3.0}
    return data


def test_planar_elongation_scene_round_trips_with_its_defaults():
    scene = Scene.from_dict(elongation_dict())
    assert scene.box.kind == "kraynik_reinelt"
    assert scene.flow.elongation_rate == 0.2 and scene.flow.kraynik_reinelt_case == 1
    data = scene.to_dict()
    assert data["flow"] == {**FLOW, "kraynik_reinelt_case": 1}
    assert Scene.from_dict(data) == scene
    box = make_box(scene.box.kind, scene.box.lengths, scene.flow)
    assert box == KraynikReineltBox((6.0, 4.0, 6.0), 0.2, 1)
    shear = Scene.from_dict(scene_dict(flow={"kind": "shear", "shear_rate": 0.3}))
    assert shear.to_dict()["flow"] == {"kind": "shear", "shear_rate": 0.3}


@pytest.mark.parametrize(
    "change, message",
    [
        ({"flow": {"kind": "planar_elongation"}}, "flow.elongation_rate: required"),
        ({"flow": {**FLOW, "shear_rate": 0.1}}, "do not belong to flow.kind"),
        ({"flow": {**FLOW, "kraynik_reinelt_case": 5}}, "kraynik_reinelt_case = 5"),
        ({"flow": {**FLOW, "kraynik_reinelt_case": 1.5}}, "expected an integer"),
        ({"box": {"kind": "lees_edwards", "lengths": [6.0, 4.0, 6.0]}}, "box.kind"),
        ({"box": {"lengths": [6.0, 4.0, 7.0]}}, "L_x = L_z"),
        ({"box": {"lengths": [2.2, 4.0, 2.2]}}, "thinnest cell height"),
        ({"box": {"lengths": [6.0, 1.9, 6.0]}}, "L_y = 1.9"),
        ({"neighbors": {"method": "jax_md"}}, "Kraynik–Reinelt"),
        (
            {"solvent": {"method": "mpcd", "cell_size": 0.7, "collision_time": 0.04}, "pair": None},
            "solvent.cell_size",
        ),
    ],
)
def test_bad_planar_elongation_input_names_the_field(change, message):
    # A section given as None is removed.
    merged = {**elongation_dict(), **change}
    data = {name: value for name, value in merged.items() if value is not None}
    with pytest.raises((ValueError, TypeError), match=message):
        Scene.from_dict(data)


def test_springs_must_fit_the_thinnest_kraynik_reinelt_cell():
    """max_extension < min(cell_heights)/2: the thinnest cell over the period (5.18
    for L = 6, case 1), here also L_y/2 = 2, not half the edge (3)."""
    data = elongation_dict(
        particles=None,
        polymers=[
            {
                "species": "chain",
                "beads": 2,
                "bond": {"law": "fene", "spring_constant": 1.0, "max_extension": 2.5},
            }
        ],
    )
    data["particles"] = {
        "count": 432,
        "species": [{"name": "solvent", "count": 392}, {"name": "chain", "count": 40}],
    }
    with pytest.raises(ValueError, match="max_extension = 2.5"):
        Scene.from_dict(data)
    data["polymers"][0]["bond"]["max_extension"] = 1.9
    assert Scene.from_dict(data).polymers[0].bond_parameters["max_extension"] == 1.9


def test_replicas_take_their_own_elongation_rates():
    """`replicate(..., flow_rates=...)` sets ε̇ per replica (each keeps its own strain);
    shear_rates are refused for elongation, flow_rates for a box at rest."""
    from jaxdpd.engine.build import build

    # Thermostat off and no pair force: nothing to compile but the (empty) kernel.
    bare = {"solvent": {"method": "dpd", "gamma": 0.0}, "pair": None}
    simulation = build(Scene.from_dict(elongation_dict(lengths=(4.5, 3.0, 4.5), **bare)))
    state = simulation.init_fn()
    batch = ensemble.replicate(simulation, state, flow_rates=[0.0, 0.3])
    np.testing.assert_allclose(np.asarray(batch.box_state.elongation_rate), [0.0, 0.3])
    stopped = flows.set_flow_rate(batch, "planar_elongation", 0.0)
    assert np.all(np.asarray(stopped.box_state.elongation_rate) == 0)
    assert stopped.box_state.elongation_rate.dtype == jnp.float64
    with pytest.raises(ValueError, match="shear_rates need a scene with a \\[flow\\] of kind"):
        ensemble.replicate(simulation, state, shear_rates=[0.1, 0.2])
    with pytest.raises(ValueError, match="2 flow rates for 3 replicas"):
        ensemble.replicate(simulation, state, count=3, flow_rates=[0.1, 0.2])
    at_rest = build(Scene.from_dict(scene_dict(**bare)))
    with pytest.raises(ValueError, match="flow_rates need a scene with a \\[flow\\]"):
        ensemble.replicate(at_rest, at_rest.init_fn(), flow_rates=[0.1])
