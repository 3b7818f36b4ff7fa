"""Small MPCD scenes shared by the MPCD tests."""


def polymer_solution(
    chains=8, beads=10, solvent_particles=1000, edge=6, seed=3, **sections
) -> dict:
    """Gaussian chains (Hookean H = 3 k_BT/l², l = 1; seed eq. 3) of monomers of mass
    M = ρm = 5 in an SRD solvent in a box of edge `edge` (ρ = 5 per cell with the
    default counts), h = 0.1, h_p = 0.01, float64.
    `sections` replace whole sections, except "solvent", which they update."""
    data = {
        "seed": seed,
        "precision": "float64",
        "box": {"lengths": [edge] * 3},
        "particles": {
            "count": solvent_particles + chains * beads,
            "species": [
                {"name": "solvent", "count": solvent_particles},
                {"name": "monomer", "count": chains * beads, "mass": 5.0},
            ],
        },
        "solvent": {"method": "mpcd", "collision_time": 0.1},
        "integrator": {"dt": 0.01},
        "polymers": [
            {
                "species": "monomer",
                "beads": beads,
                "bond": {"law": "hookean", "spring_constant": 3.0},
            }
        ],
    }
    return _merged(data, sections)


def _merged(data, sections) -> dict:
    """`data` with whole sections replaced, except "solvent", which they update."""
    for name, value in sections.items():
        if name == "solvent":
            data["solvent"].update(value)
        else:
            data[name] = value
    return data


def pure_solvent(density, angle, collision_time, length, seed=5, **sections) -> dict:
    """An SRD fluid of ρ = density per cell (a = 1) in a cubic box of edge `length`,
    α = angle (degrees), h = collision_time; `sections` as in `polymer_solution`."""
    data = {
        "seed": seed,
        "precision": "float64",
        "box": {"lengths": [length] * 3},
        "particles": {"density": density},
        "solvent": {"method": "mpcd", "rotation_angle": angle, "collision_time": collision_time},
    }
    return _merged(data, sections)
