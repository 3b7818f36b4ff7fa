"""Small example scenes shared by the components' contract tests.

Solvents and observables each provide `example_scene(precision)` (a scene that runs
in seconds); the particle solvents and the observables build theirs from the same
chain solution.  This module depends on nothing in jaxdpd, so that an observable can
use it without importing the engine.
"""


def chain_solution_example(precision: str, solvent: dict, spring_constant: float, **sections):
    """A small example scene for the contract tests of a particle solvent: 300
    particles at density 3, a fifth of them in 15 Hookean chains of 4 beads (spring
    constant as given), seed 5; `sections` add or replace whole sections."""
    return {
        "seed": 5,
        "precision": precision,
        "particles": {
            "density": 3.0,
            "count": 300,
            "species": [
                {"name": "bead", "fraction": 0.2},
                {"name": "solvent", "fraction": 0.8},
            ],
        },
        "solvent": solvent,
        "polymers": [
            {
                "species": "bead",
                "beads": 4,
                "bond": {"law": "hookean", "spring_constant": spring_constant},
            }
        ],
        **sections,
    }
