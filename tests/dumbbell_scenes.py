"""Scenes of FENE dumbbells in a DPD θ-solvent (thesis §4.2.9) for the tests."""

from conftest import make_scene


def dumbbell_solution(
    count: int,
    dumbbell_beads: int,
    spring_constant: float,
    max_extension: float,
    tracers: int = 0,
    **sections,
):
    """`count` particles at ρ = 3: `dumbbell_beads` beads in FENE dumbbells, `tracers`
    particles of a species "tracer" (for a tagged body force), the rest "solvent"; the
    same repulsion a = 25 between all species.  Other sections as conftest.make_scene.
    """
    species = [{"name": "dumbbell", "count": dumbbell_beads}]
    if tracers:
        species.append({"name": "tracer", "count": tracers})
    species.append({"name": "solvent", "count": count - dumbbell_beads - tracers})
    bond = {"law": "fene", "spring_constant": spring_constant, "max_extension": max_extension}
    return make_scene(
        particles={"density": 3.0, "count": count, "species": species},
        polymers=[{"species": "dumbbell", "beads": 2, "bond": bond}],
        **sections,
    )


def sheared_solution_with_tracers():
    """300 particles (box 4.64): 40 FENE dumbbells (H = 3, Q0 = 2), 4 tracers pulled
    by a tagged force F = 1, solvent; steady shear γ̇ = 0.3; float64; observes the
    temperature, pressure, conformation and drag."""
    return dumbbell_solution(
        300,
        80,
        3.0,
        2.0,
        tracers=4,
        flow={"kind": "shear", "shear_rate": 0.3},
        body_force={"kind": "tagged", "amplitude": 1.0, "species": "tracer"},
        output={"observables": ["temperature", "pressure", "conformation", "drag"]},
    )
