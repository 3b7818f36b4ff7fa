"""One system decomposed over devices (jaxdpd.decomposition) against the same scene on one.

The decomposed step sums each particle's forces in another order than the
single-device step, so the two trajectories differ by round-off, and the dynamics
amplifies round-off: a 1-ulp change of one coordinate grows about 10² every 25
steps, to ~1e-8 after 100 steps and to the box size after 200, and the decomposed
run stays within a factor 3 of that (docs/scaling_out.md, "Equal to what?";
`benchmarks/decomposition_divergence.py`).  After 20 steps the two differ by
~1e-13, far below the 1e-9 allowed, while a missed pair across a slab face or a
wrong halo changes a force by O(1) and positions by O(Δt²) ~ 1e-3 at once.
Momentum is conserved to round-off (thesis §2.1: pair forces are antisymmetric).
The runs need several CPU devices, which JAX fixes when it starts: each comparison
runs tests/decomposition_probe.py in a fresh process with
XLA_FLAGS=--xla_force_host_platform_device_count=D.
"""

from pathlib import Path

import pytest
from forced_devices import run_probe

from jaxdpd.scene import Scene
from jaxdpd.solvents import SOLVENTS

PROBE = Path(__file__).with_name("decomposition_probe.py")
# Round-off of a total momentum of ~10³ particles with |v| ~ 1 in float64.
MOMENTUM_ROUND_OFF = 1e-12


def probe(case: str, devices: int, steps: int = 20, equilibration: int = 0) -> dict:
    """The probe's comparison of `case` on `devices` slabs 2.5 r_c thick (as thick as
    the halo of a FENE chain, 1.5 + 0.8 r_c)."""
    length_y = 2.5 * devices
    arguments = ["--devices", str(devices), "--case", case, "--steps", str(steps)]
    arguments += ["--length-y", str(length_y), "--equilibration", str(equilibration)]
    return run_probe(PROBE, arguments)


def check_equal_to_single_device(result: dict) -> None:
    assert result["flags"] == 0
    assert result["difference"]["positions"] < 1e-9, result
    assert result["difference"]["velocities"] < 1e-9, result
    assert result["temperature_difference"] < 1e-9, result
    assert result["pressure_difference"] < 1e-9, result
    assert result["momentum"] < MOMENTUM_ROUND_OFF, result


def test_sheared_chain_solution_on_four_devices_equals_one_device():
    """Slabs normal to the gradient of a Lees–Edwards box, FENE chains across them."""
    result = probe("shear", 4)
    check_equal_to_single_device(result)
    assert result["bonds_across_slabs"] > 0, "no chain crosses a slab face: the test is void"
    assert min(result["particles_per_device"]) > 0


def test_lowe_andersen_ideal_gas_on_four_devices_is_bit_identical_to_one_device():
    """Lowe–Andersen at Γ Δt = 1 without conservative forces: every force is exactly
    zero on one device and on four, so the runs differ only if the decomposed sweep
    does (docs/scaling_out.md, "Lowe–Andersen").  Its pairs are ordered, selected and
    drawn by particle identity, and a pair across a slab face is applied by both
    devices from the same operands, so after 20 steps of ~20 rounds each the
    particles are equal bit for bit; the temperature and pressure only to round-off,
    being sums taken in another order."""
    result = probe("lowe_andersen_ideal_gas", 4)
    assert result["flags"] == 0
    assert result["difference"] == {"positions": 0.0, "velocities": 0.0}, result
    assert result["temperature_difference"] < 1e-12, result
    assert result["pressure_difference"] < 1e-12, result
    assert result["momentum"] < MOMENTUM_ROUND_OFF, result


@pytest.mark.slow
@pytest.mark.parametrize("devices", [4, 8])
@pytest.mark.parametrize(
    "case",
    [
        "fluid",
        "chains",
        "shear",
        "oscillatory",
        "elongation",
        "hoogerbrugge_koelman",
        "hoogerbrugge_koelman_shear",
        "lowe_andersen",
        "lowe_andersen_shear",
        "lowe_andersen_elongation",
        "lowe_andersen_ideal_gas",
    ],
)
def test_decomposed_run_equals_one_device(case, devices):
    """Every decomposable solvent, bonds across slabs, both flowing boxes, 4 and 8 slabs."""
    result = probe(case, devices)
    check_equal_to_single_device(result)
    if case in (
        "chains",
        "shear",
        "oscillatory",
        "lowe_andersen",
        "lowe_andersen_shear",
        "lowe_andersen_elongation",
    ):
        assert result["bonds_across_slabs"] > 0


@pytest.mark.slow
def test_a_thousand_decomposed_steps_keep_the_temperature_and_pressure():
    """After ~200 steps the decomposed and single-device trajectories are as different
    as two seeds' (docs/scaling_out.md), so over 1000 steps they are compared as
    samples of the same ensemble: block means agree within 4 combined standard
    errors (20 blocks of 50 steps each, Flyvbjerg & Petersen 1989), and momentum
    stays at round-off after the 1200 steps."""
    result = probe("chains", 4, steps=1000, equilibration=200)
    assert result["flags"] == 0
    assert result["momentum"] < MOMENTUM_ROUND_OFF
    for name in ("temperature", "pressure"):
        (split, split_error), (single, single_error) = (
            result["block_averages"][run][name] for run in ("split", "single")
        )
        assert abs(split - single) < 4 * (split_error**2 + single_error**2) ** 0.5, (name, result)


def base_scene(**sections) -> dict:
    return {
        "box": {"lengths": [6.0, 8.0, 6.0]},
        "particles": {"density": 3.0},
        "solvent": {"method": "dpd"},
        "pair": {"a": 25.0},
        "integrator": {"dt": 0.04, "lambda": 0.65},
        **sections,
    }


def test_slabs_thinner_than_the_halo_are_refused_naming_what_fits():
    with pytest.raises(ValueError) as error:
        Scene.from_dict(base_scene(parallel={"devices": 6}))
    message = str(error.value)
    assert "parallel.devices = 6" in message and "at most 4 devices along y" in message


def test_two_slabs_need_two_halos():
    """With two devices the one neighbour sits on both faces: w ≥ 2h (h = 1.8 here)."""
    split = {"devices": 2, "axis": "y"}
    with pytest.raises(ValueError, match="parallel.devices = 2"):
        Scene.from_dict(base_scene(box={"lengths": [6.0, 5.0, 6.0]}, parallel=split))
    Scene.from_dict(base_scene(box={"lengths": [6.0, 8.0, 6.0]}, parallel=split))


def test_a_method_that_cannot_be_decomposed_is_refused_naming_those_that_can():
    scene = SOLVENTS.get("mpcd").example_scene()
    scene["parallel"] = {"devices": 4}
    decomposable = [m.name for m in SOLVENTS if m.decomposition is not None]
    assert "lowe_andersen" in decomposable
    with pytest.raises(ValueError, match="solvent.method = 'mpcd'") as error:
        Scene.from_dict(scene)
    assert str(decomposable) in str(error.value)


def test_an_observable_not_measured_in_decomposed_runs_is_refused():
    scene = base_scene(
        parallel={"devices": 4},
        output={"observables": ["temperature", "dynamics"]},
        particles={
            "density": 3.0,
            "species": [{"name": "bead", "fraction": 0.2}, {"name": "solvent", "fraction": 0.8}],
        },
        polymers=[
            {"species": "bead", "beads": 4, "bond": {"law": "hookean", "spring_constant": 10.0}}
        ],
    )
    with pytest.raises(ValueError, match=r"output.observables: \['dynamics'\]") as error:
        Scene.from_dict(scene)
    assert "'conformation'" in str(error.value) and "docs/scaling_out.md" in str(error.value)


def test_an_axis_the_box_cannot_cut_is_refused():
    scene = base_scene(
        flow={"kind": "shear", "shear_rate": 0.1}, parallel={"devices": 4, "axis": "x"}
    )
    with pytest.raises(ValueError, match="parallel.axis = 'x'"):
        Scene.from_dict(scene)


def test_the_parallel_section_round_trips_and_is_absent_on_one_device():
    one = Scene.from_dict(base_scene())
    assert "parallel" not in one.to_dict()
    four = Scene.from_dict(base_scene(parallel={"devices": 4, "margin": 0.4}))
    assert Scene.from_dict(four.to_dict()) == four
    assert four.to_dict()["parallel"] == {"devices": 4, "margin": 0.4}
