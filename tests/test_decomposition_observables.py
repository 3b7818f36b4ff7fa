"""Observables of a system decomposed over devices (jaxdpd.decomposition) against the
same scene on one device.

What "equal" means follows tests/test_decomposition.py: over 20 steps the decomposed
trajectory differs from the single-device one by ~1e-13 (another summation order,
amplified by the dynamics by ~10² every 25 steps), so every per-step series must
agree within 1e-9, while a wrongly counted row (a halo copy counted as owned, a
spring or bead missed at a slab face, a chain piece read against the wrong image)
changes a series by O(1/n) of its n terms (n ≤ a few thousand) at once, far above
1e-9.  g(r) is histogrammed from the gathered configuration; positions differing
by ~1e-13 move a pair across a bin edge (width 0.02) with probability ~1e-6 per
sample, so the histograms must be equal.  Each comparison runs
tests/decomposition_observables_probe.py in a fresh process with
XLA_FLAGS=--xla_force_host_platform_device_count=D (JAX fixes its CPU devices when
it starts).
"""

from pathlib import Path

import jax.numpy as jnp
import numpy as np
import pytest
from forced_devices import run_probe

from jaxdpd.engine.ownership import Ownership
from jaxdpd.engine.parameters import scene_parameters
from jaxdpd.engine.state import SimState
from jaxdpd.geometry.boxes import make_box
from jaxdpd.geometry.chain_topology import chain_blocks
from jaxdpd.observables.chain_series import Conformation
from jaxdpd.observables.component import BuildContext
from jaxdpd.precision import enable_float64
from jaxdpd.scene import Scene

PROBE = Path(__file__).with_name("decomposition_observables_probe.py")
TOLERANCE = 1e-9  # tests/test_decomposition.py: 20 steps of float64 round-off


def probe(devices: int, case: str, lengths, max_extension: float, observables=None) -> dict:
    arguments = ["--devices", str(devices), "--case", case, "--lengths", *map(str, lengths)]
    arguments += ["--max-extension", str(max_extension)]
    if observables:
        arguments += ["--observables", *observables]
    return run_probe(PROBE, arguments, timeout=1800)


def check_equal_to_single_device(result: dict, expected_prefixes) -> None:
    assert result["flags"] == 0
    assert result["springs_across_slabs"] > 0 and result["chains_across_slabs"] > 0, (
        "no chain crosses a slab face: the test is void"
    )
    differences = result["differences"]
    missing = [name for name, difference in differences.items() if difference is None]
    assert not missing and not result["split_only"], (missing, result["split_only"])
    assert not any(result["non_finite"].values()), result["non_finite"]
    for prefix in expected_prefixes:
        assert any(name.startswith(prefix) for name in differences), (prefix, sorted(differences))
    for name, difference in differences.items():
        assert difference < TOLERANCE, (name, difference)
    if "rdf_difference" in result:
        assert result["rdf_difference"] == 0 and result["rdf_peak"] > 1, result


# Series of every decomposed observable (the chain block's species is "bead").
SERIES = ("bead/", "profile/", "transverse_current", "temperature", "pressure")
EXTENSION = ("bead/fractional_extension", "bead/end_to_end_conformation", "bead/spring_pair")


def test_every_decomposed_observable_equals_one_device_in_a_sheared_chain_solution():
    """Hookean chains in a Lees–Edwards box 7.2 r_c wide (slabs 1.8 r_c, the halo),
    every decomposing observable in one run."""
    result = probe(4, "shear", [7.2, 7.2, 7.2], 0)
    check_equal_to_single_device(result, (*SERIES, "bead/end_to_end_sq"))


@pytest.mark.slow
@pytest.mark.parametrize(
    "devices, case, lengths",
    [
        (4, "rest", [6.0, 10.0, 6.0]),
        (4, "elongation", [6.0, 10.0, 6.0]),
        (8, "shear", [6.0, 20.0, 6.0]),
    ],
)
def test_decomposed_chain_observables_equal_one_device(devices, case, lengths):
    """FENE chains (Q0 = 1.5: fractional extension) at rest (springs through image
    counters), in planar elongation (Kraynik–Reinelt, slabs along y) and in shear on
    8 slabs; the box is not cubic, so no transverse current."""
    observables = ["temperature", "pressure", "conformation", "profile", "rdf"]
    result = probe(devices, case, lengths, 1.5, observables)
    check_equal_to_single_device(result, ("bead/", "profile/", *EXTENSION))


# -- one device standing for all: the per-row algorithm against conformation_samples --


def _chain_scene(flow=None) -> Scene:
    data = {
        "precision": "float64",
        "box": {"lengths": [6.0, 6.0, 6.0]},
        "particles": {
            "count": 60,
            "species": [{"name": "bead", "fraction": 0.5}, {"name": "solvent", "fraction": 0.5}],
        },
        "polymers": [
            {"species": "bead", "beads": 10, "bond": {"law": "hookean", "spring_constant": 2.0}}
        ],
        "solvent": {"method": "dpd"},
        "pair": {"a": 25.0},
        "integrator": {"dt": 0.04},
        "output": {"observables": ["conformation", "pressure"]},
    }
    if flow is not None:
        data["flow"] = flow
    return Scene.from_dict(data)


def _samples_both_ways(scene, step_length: float):
    """(one-device samples, domain samples with every row owned by one 'device')
    of random-walk chains of steps `step_length` (r_c), wrapped into the box."""
    enable_float64()
    box = make_box(scene.box.kind, scene.box.lengths, scene.flow)
    box_state = box.initial_state(jnp.float64)
    if scene.flow is not None:  # a sheared box with a nonzero offset
        box_state = box.advance(box_state, jnp.asarray(0.0), 1.3)
    bound = box.bind(box_state)
    rng = np.random.default_rng(1)
    n = scene.n_particles
    steps = rng.normal(size=(n, 3))
    steps *= step_length / np.linalg.norm(steps, axis=1, keepdims=True)
    unwrapped = np.cumsum(steps, axis=0) + 3.0
    positions, image = bound.wrap(jnp.asarray(unwrapped), jnp.zeros((n, 3), jnp.int32))
    blocks = chain_blocks(scene)
    state = SimState(
        positions=positions,
        velocities=jnp.zeros_like(positions),
        forces=jnp.zeros_like(positions),
        image=image,
        species=jnp.zeros(n, jnp.int32),
        pair_list=None,
        virial={},
        step=0,
        time=0.0,
        seed=0,
        flags=0,
        box_state=box_state,
        parameters=scene_parameters(scene, blocks, jnp.float64),
    )
    context = BuildContext(scene, box, blocks, None, jnp.float64, None)
    component = Conformation()
    _, single = component.sampler(context)(state, state)
    identities = jnp.arange(n, dtype=jnp.int32)
    everything = Ownership(jnp.ones(n, bool), lambda x: x, identities, lambda wanted: wanted)
    return single, component.domain_sampler(context)(everything, state)


def test_one_device_domain_samples_equal_the_single_device_samples():
    """All rows owned by one 'device' whose sum over devices is the identity: the
    per-row sums equal conformation_samples up to round-off, in a box at rest with
    chains longer than the box (springs through image counters) and in a sheared box."""
    for flow, step_length in ((None, 1.5), ({"kind": "shear", "shear_rate": 0.5}, 0.4)):
        single, domain = _samples_both_ways(_chain_scene(flow), step_length)
        assert set(single) == set(domain)
        for name, value in single.items():
            np.testing.assert_allclose(domain[name], value, rtol=1e-12, atol=1e-12, err_msg=name)


def test_a_chain_reaching_past_half_a_sheared_box_gives_nan_sizes():
    """In a flowing box a bead is read against its chain's middle bead by minimum
    image; chains of 10 steps of 1.5 r_c reach past half the 6 r_c box from there,
    so their size samples are NaN (not silently wrong), while the springs are still
    read."""
    single, domain = _samples_both_ways(_chain_scene({"kind": "shear", "shear_rate": 0.5}), 1.2)
    assert np.isnan(domain["bead/gyration_radius_sq"]) and np.isnan(domain["bead/end_to_end_sq"])
    assert np.isfinite(single["bead/gyration_radius_sq"])
    np.testing.assert_allclose(domain["bead/bond_length_sq"], single["bead/bond_length_sq"])
