"""Drag coefficient ζ of a DPD bead by the two methods of thesis §4.2.4.

References:
- the tagged-particle force balances: F on each of k tagged particles, −k F/(N − k)
  on the others (thesis §4.2.4: −F_b/(N − 1) for k = 1), so Σ f = 0;
- linear response (Kubo) with momentum conservation: the drift of k tagged particles
  through the rest gives the single-bead ζ = (F/Δv)(N − 1)/(N − k), which equals
  k_BT (N − 1)²/(D N²) from the self-diffusion coefficient D of the same particles
  (Einstein relation; derivation in jaxdpd.observables.drag);
- Giesekus–Kramers comparison (thesis eq. 4.18) for DPD FENE dumbbells in steady
  shear: with the whole intramolecular force (spring plus the soft repulsion between
  the two beads) it returns ζ of the tagged-particle method; with the spring alone
  (eq. 4.18 as printed) it overestimates ζ at low De, the excluded-volume effect the
  thesis reports (fig. 4-3, §4.2.6).

Tolerances: 4 standard errors (block averages over time; D from per-particle MSD
slopes, blocked over particles), combined in quadrature.
"""

import numpy as np
import pytest
from conftest import make_scene
from dumbbell_scenes import dumbbell_solution

from jaxdpd.analysis.dynamics import diffusion_coefficient, time_msd
from jaxdpd.engine.build import build
from jaxdpd.forces.body_forces import tagged_body_force
from jaxdpd.observables.drag import einstein_drag, giesekus_drag, tagged_drag
from jaxdpd.run import driver
from jaxdpd.run.series import collect
from jaxdpd.scene import Scene

SIGMAS = 4.0


def test_tagged_force_is_balanced():
    force = tagged_body_force(3, 4, 20, np.float64)
    forces = np.asarray(force(np.zeros((20, 3)), 2.5))
    np.testing.assert_allclose(forces[3:7, 0], 2.5)
    np.testing.assert_allclose(np.delete(forces[:, 0], range(3, 7)), -2.5 * 4 / 16)
    assert abs(forces.sum()) < 1e-14 and not forces[:, 1:].any()
    with pytest.raises(ValueError, match="at least one untagged"):
        tagged_body_force(0, 20, 20, np.float64)


def tracer_scene(**changes):
    sections = {
        "particles": {
            "density": 3.0,
            "count": 600,
            "species": [{"name": "tracer", "count": 6}, {"name": "solvent", "count": 594}],
        },
        "body_force": {"kind": "tagged", "amplitude": 1.0, "species": "tracer"},
        "output": {"observables": ["temperature", "drag"]},
    }
    sections.update(changes)
    return make_scene(**sections)


@pytest.mark.parametrize(
    ("changes", "words"),
    [
        ({"body_force": {"kind": "tagged", "amplitude": 1.0}}, "body_force.species: required"),
        (
            {"body_force": {"kind": "tagged", "amplitude": 1.0, "species": "ghost"}},
            "not a particle species",
        ),
        (
            {"body_force": {"kind": "tagged", "amplitude": 1.0, "species": "tracer", "waves": 2}},
            "body_force.waves: only used with body_force.kind = 'cosine'",
        ),
        (
            {"body_force": {"kind": "cosine", "amplitude": 1.0, "species": "tracer"}},
            "body_force.species: only used with body_force.kind = 'tagged'",
        ),
        ({"body_force": None}, "'drag' measures the drift of tagged particles"),
        (
            {"particles": {"density": 3.0, "count": 600, "species": [{"name": "tracer"}]}},
            "needs at least one tagged and one untagged",
        ),
    ],
)
def test_invalid_tagged_force_fields_are_named(changes, words):
    with pytest.raises(ValueError, match=words):
        tracer_scene(**changes)


def test_tagged_force_scene_round_trips():
    scene = tracer_scene()
    assert Scene.from_dict(scene.to_dict()) == scene
    assert "waves" not in scene.to_dict()["body_force"]


@pytest.mark.slow
def test_tagged_particle_drag_equals_einstein_drag():
    """ρ = 3, a = 25, γ = 4.5, Δt = 0.04 (λ = 0.65), N = 1500 with k = 50 tagged
    particles pulled by F = 1: ζ from their drift equals k_BT (N − 1)²/(D N²) with D
    from the transverse (y, z) mean-square displacement of all particles in the same
    run (the force is along x; linear response leaves y, z at equilibrium)."""
    n, k, force, every, dt = 1500, 50, 1.0, 20, 0.04
    scene = make_scene(
        precision="float32",
        particles={
            "density": 3.0,
            "count": n,
            "species": [{"name": "tracer", "count": k}, {"name": "solvent", "count": n - k}],
        },
        integrator={"dt": dt, "lambda": 0.65},
        body_force={"kind": "tagged", "amplitude": force, "species": "tracer"},
        output={"observables": ["temperature", "drag"]},
    )
    simulation = build(scene)
    state = driver.run(simulation, simulation.init_fn(), 1000, every)
    positions = []

    def keep_positions(result):
        unwrapped = simulation.box.unwrap(result.state.positions, result.state.image)
        positions.append(np.asarray(unwrapped, np.float64))

    _, series = collect(simulation, state, 10000, every, on_chunk=keep_positions)
    positions = np.asarray(positions)
    zeta, zeta_error = tagged_drag(series["drag/relative_velocity"][:, 0], force, k, n)
    transverse = np.asarray(time_msd(positions[:, :, 1:])).sum(axis=-1)  # (T, N)
    times = np.arange(len(positions)) * every * dt
    used = times <= 8.0  # lags well sampled; the VACF has decayed after ~1 (1/ζ ≈ 0.3)
    diffusion, diffusion_error = diffusion_coefficient(
        times[used], transverse[used], fit_from=2.0, dimension=2
    )
    einstein, einstein_error = einstein_drag(diffusion, diffusion_error, n)
    print(f"ζ tagged {float(zeta):.4f} ± {float(zeta_error):.4f}, Einstein {einstein:.4f} "
          f"± {einstein_error:.4f} (D = {diffusion:.4f} ± {diffusion_error:.4f})")  # fmt: skip
    assert abs(float(zeta) - einstein) < SIGMAS * np.hypot(float(zeta_error), einstein_error)


@pytest.mark.slow
def test_giesekus_drag_of_dpd_dumbbells_against_tagged_drag():
    """FENE dumbbells b = 50, Q0 = 4 (H = 3.125) at 25 % in the DPD θ-solvent
    (thesis §4.2.9), 20 tagged solvent particles pulled by F = 1, steady shear
    γ̇ = 0.3 (De ≈ 0.08): the Giesekus ζ with the bead repulsion across the springs
    equals the tagged-particle ζ of the same run; with the spring alone (eq. 4.18) it
    is larger by more than 3 standard errors (excluded volume)."""
    q0, rate, tracers = 4.0, 0.3, 20
    n, dumbbell_beads = 1720, 430
    scene = dumbbell_solution(
        n,
        dumbbell_beads,
        50 / q0**2,
        q0,
        tracers=tracers,
        precision="float32",
        flow={"kind": "shear", "shear_rate": rate},
        body_force={"kind": "tagged", "amplitude": 1.0, "species": "tracer"},
        integrator={"dt": 0.04, "lambda": 0.65},
        output={"observables": ["temperature", "pressure", "conformation", "drag"]},
    )
    simulation = build(scene)
    state = driver.run(simulation, simulation.init_fn(), 1500, 500)
    _, series = collect(simulation, state, 10000, 500)
    zeta, zeta_error = tagged_drag(series["drag/relative_velocity"][:, 0], 1.0, tracers, n)
    density = dumbbell_beads / 2 / scene.volume
    arguments = (
        series["pressure_tensor_part/bond"],
        series["dumbbell/bond_conformation"],
        rate,
        density,
    )
    spring_only, spring_only_error = giesekus_drag(*arguments)
    whole, whole_error = giesekus_drag(
        *arguments, intramolecular_pressure=series["dumbbell/spring_pair_pressure"]
    )
    print(f"ζ tagged {float(zeta):.3f} ± {float(zeta_error):.3f}; Giesekus: spring + "
          f"repulsion {float(whole):.3f} ± {float(whole_error):.3f}, spring alone "
          f"{float(spring_only):.3f} ± {float(spring_only_error):.3f}")  # fmt: skip
    assert abs(float(whole - zeta)) < SIGMAS * float(np.hypot(whole_error, zeta_error))
    assert float(spring_only - zeta) > 3 * float(np.hypot(spring_only_error, zeta_error))
