"""Scene: a declarative, validated description of a simulation.

A scene is read from TOML (`Scene.from_toml`) or a dictionary (`Scene.from_dict`);
`Scene.to_dict` gives back the complete, resolved description (defaults filled in),
which is written into every output file and reloads to an equal scene.

Sections and fields (reduced DPD units, r_c = m = k_BT = 1):

    seed        integer in [0, 2³²)                     noise and initial state
    precision   "float32" | "float64"
    cutoff      r_c > 0 of all pair interactions        default 1 (2^(1/6) σ for
                pair.kind = "wca", which is the only value allowed then)
    [box]       kind = "periodic" | "lees_edwards" | "kraynik_reinelt" (follows from
                [flow] when not given); lengths = [Lx, Ly, Lz] (optional, see
                particles; a Kraynik–Reinelt box needs Lx = Lz)
    [flow]      kind = "shear": shear_rate γ̇ (1/time, any sign; u_x = γ̇ (y − L_y/2)),
                oscillation_frequency ω > 0 for γ̇(t) = γ̇ cos(ω t) (optional);
                needs a Lees–Edwards box and solvent.method "dpd", "lowe_andersen" or
                "mpcd" (MPCD shear: the viscosity is −⟨P_yx⟩/γ̇, the collisional stress
                is not symmetric)
                kind = "planar_elongation": elongation_rate ε̇ (1/time, any sign;
                u = ε̇ (−(x − x0), 0, z − z0), thesis eq. 5.12), kraynik_reinelt_case
                = 1..4 (lattice of thesis table 3.27, default 1); needs a
                Kraynik–Reinelt box and solvent.method "dpd" or "lowe_andersen"
    [particles] density ρ > 0 and/or count N ≥ 2; species = [{name, count|fraction,
                mass}] (mass > 0 in units of m, default 1)
                with box.lengths give one of density/count; without, give both
                (cubic box of side (N/ρ)^(1/3))
    [solvent]   method = "dpd" (Groot–Warren): kT > 0, gamma ≥ 0 (0 = thermostat
                off), optional sigma (must equal √(2γkT)), noise = "uniform"|"gaussian"
                method = "hoogerbrugge_koelman": pi0, omega, delta_pi (half-width);
                weight_density n > 0 of W(r) = 3(1 − r/r_c)/(π n r_c³) (default the
                box's N/V); initial_kT > 0 (default 0.0016): the model sets no
                temperature (its own follows from pi0, omega, delta_pi and n), so this is
                the temperature of the starting velocities, the Hookean bond length the
                chains are placed with and the scale of the runaway check
                method = "lowe_andersen": kT > 0, collision_frequency Γ ≥ 0 (0 =
                thermostat off; Γ · integrator.dt ≤ 1), thermalization_cutoff r_T > 0
                (default: cutoff)
                method = "lattice_boltzmann" (fluctuating D3Q19 fluid with friction-
                coupled beads; the particles are the beads): kT ≥ 0 (0 = no
                fluctuations), grid_spacing a > 0 (box edges whole multiples of it),
                time_step τ > 0 (a whole multiple of integrator.dt), mass_density ρ > 0,
                kinematic_viscosity ν > 0, kinematic_bulk_viscosity ν_b > 0 (default
                ν), friction ζ > 0 (bare bead–fluid friction), noise = "uniform"|
                "gaussian"; units are the scene's own (e.g. Lennard-Jones units)
                method = "mpcd" (stochastic rotation dynamics, Mussawisade et al. 2005
                §II): kT > 0 (initial velocities, thermostat), cell_size a > 0
                (every box edge a whole multiple ≥ 2), rotation_angle α in (0, 180]
                degrees (default 130), collision_time h > 0 (default 0.1),
                thermostat = "none" | "maxwell_boltzmann_scaling" (cell level,
                Huang et al. 2010), collision = "cell" (SRD) | "particle" (the
                solvent-free Rouse variant, §IV.A: every particle must be a monomer);
                particles per cell ρ = particles.density · a³.  Solvent particles
                stream freely; monomers move by velocity Verlet with integrator.dt =
                h_p (h/h_p a whole number, default h_p = h) and join the collisions
                with their species masses
    [pair]      kind = "soft_repulsion"; a = number | S×S symmetric list |
                {"A-B" = a_AB, ...} over species names (dpd, lowe_andersen; with mpcd it acts
                among the [[polymers]] species only)
                kind = "wca": epsilon > 0, sigma > 0 (Weeks–Chandler–Andersen,
                cut-off 2^(1/6) σ)
    [[polymers]] species = name of a particle species whose particles are chained,
                beads = beads per linear chain (≥ 2; the species count must be a
                multiple, fractions are rounded to one); bond = {law, ...} with
                law = "hookean" (spring_constant) | "fraenkel" or "harmonic"
                (spring_constant, rest_length) | "fene" (spring_constant, max_extension) |
                "fene_log_wca" (spring_constant, max_extension, wca_epsilon = 1,
                wca_sigma = 1); every solvent method (with mpcd the chained species
                must be adjacent in particles.species; with hoogerbrugge_koelman the
                beads are fluid particles that also exchange spring impulses, Schlijper,
                Hoogerbrugge & Manke, J. Rheol. 39, 567 (1995))
    [body_force] kind = "cosine": amplitude F (force per particle), waves n ≥ 1:
                f_x = F cos(2π n y/L_y) on every particle (periodic Poiseuille flow)
                kind = "tagged": amplitude F, species = name: f_x = F on each of the
                k particles of that species, −k F/(N − k) on every other one (drag
                coefficient, thesis §4.2.4)
    [spring_repulsion] between the springs of all chains (thesis §5.2;
                jaxdpd.forces.spring_repulsion):
                law = "exponential" (A = 100 k_BT, alpha = 10/r_c; Kumar–Larson eq. 5.6)
                | "linear" (a, force 3a(1 − D/range) at contact distance D; Pan–Manke
                eq. 5.5); range = r_c/3 > 0; distance_floor = 0.001 r_c (≥ 0, < range);
                needs [[polymers]]
    [integrator] dt > 0 (default 1 for hoogerbrugge_koelman, solvent.time_step for
                lattice_boltzmann); lambda in [0, 1] (dpd only: Lowe–Andersen and
                lattice-Boltzmann steps have no velocity-dependent force to predict)
    [neighbors] method = "cell_list" | "jax_md" | "all_pairs" (every pair, fixed: for
                small systems such as one chain); format (jax_md) = "dense" |
                "sparse" | "ordered_sparse"; skin ≥ 0; capacity_multiplier ≥ 1;
                spring_skin ≥ 0 (default 0.5: skin of the spring-pair list, used with
                [spring_repulsion] or the "spring_pairs" observable)
    [run]       steps ≥ 0, chunk ≥ 1, equilibration ≥ 0 (steps run before sampling)
    [output]    path (H5MD file, optional); observables ⊂ {"temperature",
                "pressure", "rdf", "conformation", "dynamics", "profile",
                "transverse_current", "drag" (needs body_force.kind = "tagged"),
                "spring_pairs"} (default temperature and pressure; no pressure with
                lattice_boltzmann); rdf_bins, rdf_max; profile_bins ≥ 1 (slabs along y);
                spring_pair_bins ≥ 1, spring_pair_max > 0 (default r_c/3: histogram of
                spring closest approaches, and spring crossings; needs [[polymers]]);
                trajectory_every (0 = never); correlator_every ≥ 1 (steps between
                samples of the "dynamics" correlators), correlator_levels ≥ 1;
                current_modes ≥ 1 (transverse currents at k = 2πn/L, n = 1 ..
                current_modes; cubic boxes); checkpoint_every (steps, 0 = none
                by step count); checkpoint_seconds ≥ 0 (wall-clock seconds between
                checkpoints, default 300, 0 = none by time); checkpoints are also
                written at the end, on errors and on SIGINT/SIGTERM; trajectory_every
                and checkpoint_every are multiples of run.chunk
"""

import json
import math
import tomllib
from dataclasses import asdict, dataclass, field
from fractions import Fraction

from jaxdpd.forces.spring_repulsion import SPRING_REPULSION_LAWS
from jaxdpd.geometry.boxes import make_box
from jaxdpd.observables import OBSERVABLES
from jaxdpd.solvents.mpcd.cells import collision_grid
from jaxdpd.validation import (
    REQUIRED,
    SceneError,
    check_keys,
    read_choice,
    read_list,
    read_number,
    read_string,
)

SOLVENT_METHODS = ("dpd", "hoogerbrugge_koelman", "lowe_andersen", "lattice_boltzmann", "mpcd")
MPCD_THERMOSTATS = ("none", "maxwell_boltzmann_scaling")
MPCD_COLLISIONS = ("cell", "particle")
LOWE_ANDERSEN_KEYS = ("collision_frequency", "thermalization_cutoff")
LATTICE_BOLTZMANN_FIELDS = (
    "grid_spacing",
    "time_step",
    "mass_density",
    "kinematic_viscosity",
    "kinematic_bulk_viscosity",
    "friction",
)
PAIR_KINDS = ("soft_repulsion", "wca")
# Largest thermal Mach number² k_BT/(ρ a³ c_s²) of a lattice-Boltzmann node: beyond it
# the density fluctuations (its square root) make negative densities likely.
MAX_THERMAL_MACH_NUMBER_SQ = 0.1
NOISE_LAWS = ("uniform", "gaussian")
PRECISIONS = ("float32", "float64")
NEIGHBOR_METHODS = ("cell_list", "jax_md", "all_pairs")
JAX_MD_FORMATS = ("dense", "sparse", "ordered_sparse")
BOX_KINDS = ("periodic", "lees_edwards", "kraynik_reinelt")
FLOW_KINDS = ("shear", "planar_elongation")
BOX_OF_FLOW = {None: "periodic", "shear": "lees_edwards", "planar_elongation": "kraynik_reinelt"}
# The fields of each flow kind in the [flow] section.
FLOW_FIELDS = {
    "shear": ("shear_rate", "oscillation_frequency"),
    "planar_elongation": ("elongation_rate", "kraynik_reinelt_case"),
}
FLOW_SOLVENTS = ("dpd", "lowe_andersen", "mpcd")
# Solvents with a Kraynik–Reinelt (planar elongation) step: the pair-based ones.
ELONGATION_SOLVENTS = ("dpd", "lowe_andersen")
BODY_FORCE_KINDS = ("cosine", "tagged")
MAX_PARTICLES = 2**31 - 1  # particle indices are int32


@dataclass(frozen=True)
class Species:
    """A particle species, how many particles it has and their mass (units of m)."""

    name: str
    count: int
    mass: float = 1.0


@dataclass(frozen=True)
class Particles:
    """Resolved particle numbers: total count, density and species."""

    count: int
    density: float
    species: tuple[Species, ...]


@dataclass(frozen=True)
class Box:
    """The box: its kind and resolved edge lengths."""

    kind: str
    lengths: tuple[float, float, float]


@dataclass(frozen=True)
class Flow:
    """An imposed homogeneous flow (SLLOD with flow-adapted boundaries).

    Attributes:
        kind: "shear" or "planar_elongation".
        shear_rate: γ̇ (its amplitude for an oscillatory shear), 1/time (shear).
        oscillation_frequency: ω of γ̇(t) = γ̇ cos(ω t), or None for steady shear.
        elongation_rate: ε̇, 1/time (planar elongation: z stretches, x compresses).
        kraynik_reinelt_case: the lattice orientation of thesis table 3.27 (1–4).
    """

    kind: str
    shear_rate: float = 0.0
    oscillation_frequency: float | None = None
    elongation_rate: float = 0.0
    kraynik_reinelt_case: int = 1


@dataclass(frozen=True)
class Solvent:
    """Solvent method and its parameters (unused ones stay at their defaults).

    `kT` is the set temperature k_BT, except for "hoogerbrugge_koelman", which has
    none: there it is the scene's initial_kT (see HOOGERBRUGGE_KOELMAN_KT), the
    temperature the velocities start at and chains are placed for.  `weight_density`
    is the n of the Hoogerbrugge–Koelman weight function, None for the box's N/V.
    """

    method: str
    kT: float = 1.0
    gamma: float = 4.5
    noise: str = "uniform"
    pi0: float = 1.0 / 3.0
    omega: float = 4.0 / 3.0
    delta_pi: float = 1.0 / 3.0
    weight_density: float | None = None
    collision_frequency: float = 0.0
    thermalization_cutoff: float | None = None
    grid_spacing: float = 1.0
    time_step: float = 1.0
    mass_density: float = 1.0
    kinematic_viscosity: float = 1.0
    kinematic_bulk_viscosity: float = 1.0
    friction: float = 1.0
    cell_size: float = 1.0
    rotation_angle: float = 130.0
    collision_time: float = 0.1
    thermostat: str = "none"
    collision: str = "cell"

    @property
    def sigma(self) -> float:
        """Random-force amplitude σ = √(2 γ k_BT) (thesis eq. 2.8)."""
        return math.sqrt(2 * self.gamma * self.kT)

    @property
    def rotation_angle_radians(self) -> float:
        """The MPCD rotation angle α in radians (the scene gives degrees)."""
        return math.radians(self.rotation_angle)


@dataclass(frozen=True)
class Pair:
    """Conservative pair force: soft repulsion with species matrix a (S×S), or the
    WCA repulsion with epsilon and sigma (the same for all pairs)."""

    kind: str
    a: tuple[tuple[float, ...], ...] = ()
    epsilon: float = 1.0
    sigma: float = 1.0


@dataclass(frozen=True)
class Polymer:
    """Linear bead-spring chains made of all particles of one species.

    Attributes:
        species: the species name; its particles, in index order, form the chains
            bead after bead.
        beads: beads per chain M (M − 1 springs).
        bond: the bond law's table: {"law": name, parameter: value, ...}.
    """

    species: str
    beads: int
    bond: tuple[tuple[str, object], ...]

    @property
    def bond_parameters(self) -> dict:
        """The bond table as a dictionary."""
        return dict(self.bond)


@dataclass(frozen=True)
class BodyForce:
    """An external force on every particle (jaxdpd.forces.body_forces).

    Attributes:
        kind: "cosine": f_x = amplitude cos(2π waves y / L_y); "tagged": f_x =
            amplitude on the particles of `species`, −amplitude k/(N − k) on the others.
        amplitude: F, force per (tagged) particle.
        waves: n, periods across the box along y (cosine).
        species: the tagged species (tagged).
    """

    kind: str
    amplitude: float
    waves: int = 1
    species: str | None = None


@dataclass(frozen=True)
class SpringRepulsion:
    """Repulsion between the springs of every chain (jaxdpd.forces.spring_repulsion).

    Attributes:
        law: "exponential" or "linear".
        parameters: the law's parameters ((name, value), ...): A and alpha, or a.
        range: D_c, the closest-approach distance from which on the force is zero.
        distance_floor: D_min, the distance closer springs are treated as being at.
    """

    law: str
    parameters: tuple[tuple[str, float], ...]
    range: float
    distance_floor: float

    def table(self) -> dict:
        """The section as a flat dictionary (law, its parameters, range, floor)."""
        return {
            "law": self.law,
            **dict(self.parameters),
            "range": self.range,
            "distance_floor": self.distance_floor,
        }


@dataclass(frozen=True)
class Integrator:
    """Time step and the λ of the modified velocity-Verlet scheme (thesis eq. 2.10)."""

    dt: float
    lambda_: float = 0.5


@dataclass(frozen=True)
class Neighbors:
    """Neighbour search settings."""

    method: str = "cell_list"
    format: str = "ordered_sparse"
    skin: float = 0.0
    capacity_multiplier: float = 1.25
    spring_skin: float = 0.5


@dataclass(frozen=True)
class Run:
    """Run length and chunking (steps per jitted `lax.scan`)."""

    steps: int = 1000
    chunk: int = 100
    equilibration: int = 0


@dataclass(frozen=True)
class Output:
    """What is measured and where it is written.

    `settings` holds the [output] fields the registered observables own
    (jaxdpd.observables.component.Setting), as (name, value) pairs; each reads as an
    attribute (`output.rdf_bins`).
    """

    path: str | None = None
    observables: tuple[str, ...] = ("temperature", "pressure")
    trajectory_every: int = 0
    checkpoint_every: int = 0
    checkpoint_seconds: float = 300.0
    settings: tuple[tuple[str, object], ...] = ()

    def __getattr__(self, name: str):
        for key, value in self.__dict__.get("settings", ()):
            if key == name:
                return value
        raise AttributeError(f"Output has no field or observable setting {name!r}")

    def to_dict(self) -> dict:
        """The section as plain data, the observables' settings among its fields."""
        data = {
            "path": self.path,
            "observables": list(self.observables),
            "trajectory_every": self.trajectory_every,
            "checkpoint_every": self.checkpoint_every,
            "checkpoint_seconds": self.checkpoint_seconds,
            **dict(self.settings),
        }
        if self.path is None:
            del data["path"]
        return data


@dataclass(frozen=True)
class Scene:
    """A complete, validated simulation description (see the module docstring)."""

    seed: int
    precision: str
    cutoff: float
    box: Box
    particles: Particles
    solvent: Solvent
    pair: Pair | None
    integrator: Integrator
    polymers: tuple[Polymer, ...] = ()
    flow: Flow | None = None
    body_force: BodyForce | None = None
    spring_repulsion: SpringRepulsion | None = None
    neighbors: Neighbors = field(default_factory=Neighbors)
    run: Run = field(default_factory=Run)
    output: Output = field(default_factory=Output)

    # -- construction -------------------------------------------------------------
    @classmethod
    def from_toml(cls, path) -> "Scene":
        """Read and validate a scene file."""
        with open(path, "rb") as handle:
            raw = handle.read()
        try:
            text = raw.decode("utf-8")
        except UnicodeDecodeError as error:
            raise ValueError(
                f"{path}: not UTF-8 text (byte {error.start} is {raw[error.start]:#04x}); "
                "TOML scene files are UTF-8"
            ) from None
        return cls.from_toml_string(text, source=str(path))

    @classmethod
    def from_toml_string(cls, text: str, source: str = "scene") -> "Scene":
        """Validate a scene given as TOML text (`source` names it in errors)."""
        try:
            data = tomllib.loads(text)
        except tomllib.TOMLDecodeError as error:
            raise ValueError(f"{source}: not valid TOML ({error})") from None
        return cls.from_dict(data)

    @classmethod
    def from_dict(cls, data: dict) -> "Scene":
        """Validate a scene dictionary; errors name the field and the valid range."""
        check_keys(
            data,
            (
                "seed",
                "precision",
                "cutoff",
                "box",
                "particles",
                "solvent",
                "pair",
                "integrator",
                "polymers",
                "flow",
                "body_force",
                "spring_repulsion",
                "neighbors",
                "run",
                "output",
            ),
            "scene",
        )
        seed = read_number(data, "seed", "", 0, minimum=0, maximum=2**32 - 1, integer=True)
        precision = read_choice(data, "precision", "", PRECISIONS, "float32")
        cutoff = read_number(data, "cutoff", "", 1.0, minimum=0, exclusive_minimum=True)
        if "solvent" not in data:
            raise ValueError(f"solvent: required section is missing; method: {SOLVENT_METHODS}")
        solvent = _read_solvent(data["solvent"])
        neighbors = _read_neighbors(data.get("neighbors", {}))
        flow = _read_flow(data.get("flow"), solvent, neighbors)
        box_section = data.get("box", {})
        check_keys(box_section, ("kind", "lengths"), "box")
        box_kind = read_choice(box_section, "kind", "box", BOX_KINDS, BOX_OF_FLOW[_kind(flow)])
        if box_kind != BOX_OF_FLOW[_kind(flow)]:
            raise ValueError(
                f"box.kind = {box_kind!r} does not fit flow.kind = {_kind(flow)!r}: "
                f"that flow needs box.kind = {BOX_OF_FLOW[_kind(flow)]!r} (or leave box.kind out)"
            )
        lengths = _read_lengths(box_section)
        polymer_entries = _polymer_entries(data.get("polymers", []))
        chain_lengths = {
            entry["species"]: entry["beads"]
            for entry in polymer_entries
            if isinstance(entry.get("species"), str) and isinstance(entry.get("beads"), int)
        }
        particles, lengths = _read_particles(data.get("particles"), lengths, chain_lengths)
        pair = _read_pair(data.get("pair"), solvent, particles.species)
        if pair is not None and pair.kind == "wca":
            cutoff = _wca_cutoff(data, pair)
        range_name, pair_range = _pair_range(cutoff, solvent)
        list_cutoff = pair_range + neighbors.skin
        heights = make_box(box_kind, lengths, flow).cell_heights
        for axis, length, height in zip("xyz", lengths, heights, strict=True):
            if not height > 2 * list_cutoff:
                tilted = f" (its thinnest cell height {height:.4g} as the box deforms)"
                raise ValueError(
                    f"box.lengths: L_{axis} = {length:.4g}{tilted if height != length else ''} "
                    f"must exceed 2 ({range_name} + neighbors.skin) = {2 * list_cutoff:.4g}; "
                    "enlarge the box or add particles"
                )
        if solvent.method == "hoogerbrugge_koelman" and any(
            s.mass != 1.0 for s in particles.species
        ):
            raise ValueError(
                "particles.species[].mass: the Hoogerbrugge–Koelman update is written for "
                "unit masses; remove the masses or use solvent.method = 'dpd'"
            )
        integrator = _read_integrator(data.get("integrator"), solvent)
        _check_collision_probability(solvent, integrator)
        if solvent.method == "lattice_boltzmann":
            _check_lattice(solvent, lengths, integrator)
        polymers = _read_polymers(polymer_entries, particles.species)
        if solvent.method == "mpcd":
            _check_mpcd(solvent, lengths, particles.species, polymers, pair)
        run = _read_run(data.get("run", {}))
        output = _read_output(data.get("output", {}), run.chunk, solvent, cutoff)
        spring_repulsion = _read_spring_repulsion(data.get("spring_repulsion"), polymers, cutoff)
        if solvent.method == "mpcd" and (
            spring_repulsion is not None or "spring_pairs" in output.observables
        ):
            raise ValueError(
                "spring_repulsion / output.observables 'spring_pairs': not available with "
                "solvent.method = 'mpcd' (its monomer step does not carry the spring-pair "
                "list); remove them"
            )
        _check_spring_reach(spring_repulsion, output, neighbors, heights)
        # Springs must stay shorter than half the box where they are read by minimum
        # image: in a flowing box (Kraynik–Reinelt counters give no unwrapped
        # coordinates; Lees–Edwards springs keep the minimum image and its continuity
        # check) and by the spring-pair list.  Half the shortest edge, or half the thinnest
        # Kraynik–Reinelt cell.  A periodic box at rest unwraps them by image counters.
        if (
            box_kind != "periodic"
            or spring_repulsion is not None
            or ("spring_pairs" in output.observables)
        ):
            spring_room = (
                (min(heights), "the thinnest Kraynik–Reinelt cell", "thesis §3.4.3")
                if box_kind == "kraynik_reinelt"
                else (min(lengths), "the shortest box edge", "thesis §3.2.3")
            )
            _check_spring_room(polymers, spring_room)
        body_force = _read_body_force(data.get("body_force"), solvent, particles)
        scene = cls(
            seed=seed,
            precision=precision,
            cutoff=cutoff,
            box=Box(box_kind, lengths),
            particles=particles,
            solvent=solvent,
            pair=pair,
            integrator=integrator,
            polymers=polymers,
            flow=flow,
            body_force=body_force,
            spring_repulsion=spring_repulsion,
            neighbors=neighbors,
            run=run,
            output=output,
        )
        _check_observables(scene)
        return scene

    # -- derived quantities --------------------------------------------------------
    @property
    def n_particles(self) -> int:
        """Total number of particles N."""
        return self.particles.count

    @property
    def step_time(self) -> float:
        """Simulated time per step: the collision time h of an MPCD solvent (its
        monomer sub-steps integrator.dt run inside the step), else integrator.dt."""
        if self.solvent.method == "mpcd":
            return self.solvent.collision_time
        return self.integrator.dt

    @property
    def volume(self) -> float:
        """Box volume."""
        return math.prod(self.box.lengths)

    @property
    def spring_reach(self) -> float | None:
        """The largest spring closest-approach distance any term or observable reads
        (the spring-pair list's reach), or None when nothing reads spring pairs."""
        reaches = []
        if self.spring_repulsion is not None:
            reaches.append(self.spring_repulsion.range)
        if "spring_pairs" in self.output.observables:
            reaches.append(self.output.spring_pair_max)
        return max(reaches) if reaches else None

    @property
    def particle_momentum_conserved(self) -> bool:
        """Whether the particles' total momentum is constant (False for beads that
        exchange momentum with a lattice-Boltzmann fluid): 3N − 3 or 3N kinetic
        degrees of freedom."""
        return self.solvent.method != "lattice_boltzmann"

    def species_range(self, name: str) -> tuple[int, int]:
        """(first index, count) of the particles of species `name` (stored species
        after species)."""
        first = 0
        for species in self.particles.species:
            if species.name == name:
                return first, species.count
            first += species.count
        raise ValueError(f"species {name!r}: not in the scene's species {self.species_names}")

    @property
    def species_names(self) -> tuple[str, ...]:
        """Species names in index order."""
        return tuple(s.name for s in self.particles.species)

    def to_dict(self) -> dict:
        """The full resolved scene as plain data; `from_dict` reloads it unchanged."""
        data = asdict(self)
        data["integrator"]["lambda"] = data["integrator"].pop("lambda_")
        if self.solvent.method in ("lowe_andersen", "lattice_boltzmann"):
            del data["integrator"]["lambda"]
        data["box"]["lengths"] = list(self.box.lengths)
        data["particles"] = {
            "count": self.particles.count,
            "species": [
                {"name": s.name, "count": s.count, "mass": s.mass} for s in self.particles.species
            ],
        }
        data["solvent"] = _solvent_dict(self.solvent)
        if self.pair is None:
            del data["pair"]
        elif self.pair.kind == "wca":
            data["pair"] = {"kind": "wca", "epsilon": self.pair.epsilon, "sigma": self.pair.sigma}
        else:
            data["pair"] = {"kind": self.pair.kind, "a": [list(row) for row in self.pair.a]}
        data["polymers"] = [
            {"species": p.species, "beads": p.beads, "bond": p.bond_parameters}
            for p in self.polymers
        ]
        if not self.polymers:
            del data["polymers"]
        if self.body_force is None:
            del data["body_force"]
        elif self.body_force.kind == "cosine":
            del data["body_force"]["species"]
        else:
            del data["body_force"]["waves"]
        if self.spring_repulsion is None:
            del data["spring_repulsion"]
        else:
            data["spring_repulsion"] = self.spring_repulsion.table()
        if self.flow is None:
            del data["flow"]
        else:
            data["flow"] = {
                "kind": self.flow.kind,
                **{
                    name: value
                    for name in FLOW_FIELDS[self.flow.kind]
                    if (value := getattr(self.flow, name)) is not None
                },
            }
        if self.neighbors.method != "jax_md":
            del data["neighbors"]["format"]
        if self.neighbors.method == "all_pairs":
            del data["neighbors"]["skin"]
        data["output"] = self.output.to_dict()
        return data

    def to_json(self) -> str:
        """`to_dict` as JSON text (stored in output files)."""
        return json.dumps(self.to_dict(), sort_keys=True)

    def replace(self, **sections) -> "Scene":
        """A copy with whole sections or fields replaced, validated again.

        Example: `scene.replace(integrator={"dt": 0.02})` merges into the section.
        """
        data = self.to_dict()
        for name, value in sections.items():
            if isinstance(value, dict) and isinstance(data.get(name), dict):
                data[name] = {**data[name], **value}
            else:
                data[name] = value
        return Scene.from_dict(data)


def _solvent_dict(solvent: Solvent) -> dict:
    if solvent.method == "lattice_boltzmann":
        fields = {name: getattr(solvent, name) for name in LATTICE_BOLTZMANN_FIELDS}
        return {"method": solvent.method, "kT": solvent.kT, "noise": solvent.noise, **fields}
    if solvent.method == "mpcd":
        return {"method": "mpcd", "kT": solvent.kT} | {
            key: getattr(solvent, key) for key in MPCD_FIELDS
        }
    if solvent.method == "dpd":
        return {
            "method": "dpd",
            "kT": solvent.kT,
            "gamma": solvent.gamma,
            "noise": solvent.noise,
        }
    if solvent.method == "lowe_andersen":
        data = {
            "method": "lowe_andersen",
            "kT": solvent.kT,
            "collision_frequency": solvent.collision_frequency,
        }
        if solvent.thermalization_cutoff is not None:
            data["thermalization_cutoff"] = solvent.thermalization_cutoff
        return data
    data = {
        "method": solvent.method,
        "pi0": solvent.pi0,
        "omega": solvent.omega,
        "delta_pi": solvent.delta_pi,
        "initial_kT": solvent.kT,
    }
    if solvent.weight_density is not None:
        data["weight_density"] = solvent.weight_density
    return data


MPCD_FIELDS = ("cell_size", "rotation_angle", "collision_time", "thermostat", "collision")
HOOGERBRUGGE_KOELMAN_FIELDS = ("pi0", "omega", "delta_pi", "weight_density", "initial_kT")
# Default initial_kT of a Hoogerbrugge–Koelman scene: the kinetic temperature its
# default fluid reaches by itself (Π0 = 1/3, ω = 4/3, Δ = 1/3, n = 3, δt = 1:
# 0.00161 ± 0.000002, benchmarks/accuracy_cost.py, README accuracy table).  Starting
# there instead of at 1 matters for chains: a Hookean spring placed for k_BT = 1
# (√(3/K) ≈ 22 r_c at K = 0.006) or kicked by beads 600 times too hot tears far
# past the box before the fluid's friction (≈ ω Σ_j W_ij ≈ 4/3 per collision) cools
# it.  Other parameter sets reach other temperatures: measure it and set initial_kT.
HOOGERBRUGGE_KOELMAN_KT = 0.0016
DPD_FIELDS = ("gamma", "sigma", "noise")


SOLVENT_FIELDS = {
    "dpd": DPD_FIELDS,
    "hoogerbrugge_koelman": HOOGERBRUGGE_KOELMAN_FIELDS,
    "lowe_andersen": LOWE_ANDERSEN_KEYS,
    "lattice_boltzmann": (*LATTICE_BOLTZMANN_FIELDS, "noise"),
    "mpcd": MPCD_FIELDS,
}


def _refuse_fields_of_other_methods(section, method: str) -> None:
    """Fields that belong to another solvent method are an error, not ignored."""
    own = set(SOLVENT_FIELDS[method])
    for owner, fields in SOLVENT_FIELDS.items():
        misplaced = sorted((set(fields) - own) & set(section))
        if owner != method and misplaced:
            raise ValueError(f"solvent: {misplaced} belong to method {owner!r}, not {method!r}")


def _read_mpcd_solvent(section) -> Solvent:
    """The MPCD (SRD) solvent fields (module docstring)."""
    path = "solvent"
    return Solvent(
        "mpcd",
        kT=read_number(section, "kT", path, 1.0, minimum=0, exclusive_minimum=True),
        cell_size=read_number(section, "cell_size", path, 1.0, minimum=0, exclusive_minimum=True),
        rotation_angle=read_number(
            section, "rotation_angle", path, 130.0, minimum=0, exclusive_minimum=True, maximum=180
        ),
        collision_time=read_number(
            section, "collision_time", path, 0.1, minimum=0, exclusive_minimum=True
        ),
        thermostat=read_choice(section, "thermostat", path, MPCD_THERMOSTATS, "none"),
        collision=read_choice(section, "collision", path, MPCD_COLLISIONS, "cell"),
    )


def _read_solvent(section) -> Solvent:
    check_keys(
        section,
        ("method", "kT", *(field for fields in SOLVENT_FIELDS.values() for field in fields)),
        "solvent",
    )
    method = read_choice(section, "method", "solvent", SOLVENT_METHODS)
    readers = {
        "lowe_andersen": _read_lowe_andersen,
        "lattice_boltzmann": _read_lattice_boltzmann,
        "mpcd": _read_mpcd_solvent,
    }
    if method in readers:
        solvent = readers[method](section)  # their own messages for common mistakes
        _refuse_fields_of_other_methods(section, method)
        return solvent
    _refuse_fields_of_other_methods(section, method)
    if method == "dpd":
        kT = read_number(section, "kT", "solvent", 1.0, minimum=0, exclusive_minimum=True)
        gamma = read_number(section, "gamma", "solvent", 4.5, minimum=0)
        if "sigma" in section:
            sigma = read_number(section, "sigma", "solvent", minimum=0)
            expected = math.sqrt(2 * gamma * kT)
            if not math.isclose(sigma, expected, rel_tol=1e-9, abs_tol=1e-12):
                raise ValueError(
                    f"solvent.sigma = {sigma!r}: fluctuation–dissipation requires "
                    f"σ = √(2 γ kT) = {expected:.6g}; give gamma (and kT) only, or a "
                    "consistent sigma"
                )
        noise = read_choice(section, "noise", "solvent", NOISE_LAWS, "uniform")
        return Solvent(method, kT=kT, gamma=gamma, noise=noise)
    if "kT" in section:
        raise ValueError(
            f"solvent: ['kT'] belongs to the methods that set a temperature, not {method!r}, "
            "whose temperature follows from pi0, omega, delta_pi and the density; give "
            "solvent.initial_kT for the starting velocities and chain placement"
        )
    positive = {"minimum": 0, "exclusive_minimum": True}
    return Solvent(
        method,
        kT=read_number(section, "initial_kT", "solvent", HOOGERBRUGGE_KOELMAN_KT, **positive),
        pi0=read_number(section, "pi0", "solvent", 1.0 / 3.0),
        omega=read_number(section, "omega", "solvent", 4.0 / 3.0, minimum=0),
        delta_pi=read_number(section, "delta_pi", "solvent", 1.0 / 3.0, minimum=0),
        weight_density=read_number(section, "weight_density", "solvent", None, **positive),
    )


def _read_lowe_andersen(section) -> Solvent:
    """The Lowe–Andersen thermostat's parameters (thesis §2.3.2)."""
    misplaced = sorted({"gamma", "sigma", "noise", "pi0", "omega", "delta_pi"} & set(section))
    if misplaced:
        raise ValueError(
            f"solvent: {misplaced} are not parameters of method 'lowe_andersen' (it has "
            f"kT and {list(LOWE_ANDERSEN_KEYS)}; the pair collisions replace the "
            "dissipative and random forces)"
        )
    if "collision_frequency" not in section:
        raise ValueError(
            "solvent.collision_frequency: required field is missing (the bath collision "
            "frequency Γ of method 'lowe_andersen', ≥ 0, with Γ · integrator.dt ≤ 1)"
        )
    return Solvent(
        "lowe_andersen",
        kT=read_number(section, "kT", "solvent", 1.0, minimum=0, exclusive_minimum=True),
        collision_frequency=read_number(section, "collision_frequency", "solvent", minimum=0),
        thermalization_cutoff=read_number(
            section, "thermalization_cutoff", "solvent", None, minimum=0, exclusive_minimum=True
        ),
    )


def _pair_range(cutoff: float, solvent: Solvent) -> tuple[str, float]:
    """(field name, value) of the longest pair range: r_c, or a longer r_T."""
    if solvent.thermalization_cutoff is not None and solvent.thermalization_cutoff > cutoff:
        return "solvent.thermalization_cutoff", solvent.thermalization_cutoff
    return "cutoff", cutoff


def _check_collision_probability(solvent: Solvent, integrator: Integrator) -> None:
    """Γ Δt is the probability that a pair is thermalised in a step: at most 1."""
    if solvent.method != "lowe_andersen":
        return
    frequency, dt = solvent.collision_frequency, integrator.dt
    if frequency * dt > 1 + 1e-12:
        raise ValueError(
            f"solvent.collision_frequency × integrator.dt = {frequency:g} × {dt:g} = "
            f"{frequency * dt:.4g} > 1: Γ Δt is the probability that a pair is thermalised "
            f"in a step (thesis §2.3.2); use collision_frequency ≤ 1/dt = {1 / dt:.6g} "
            f"or integrator.dt ≤ 1/collision_frequency = {1 / frequency:.6g}"
        )


def _read_lattice_boltzmann(section) -> Solvent:
    """The fields of solvent.method = "lattice_boltzmann" (see the module docstring)."""
    misplaced = sorted({"gamma", "sigma", "pi0", "omega", "delta_pi"} & set(section))
    if misplaced:
        raise ValueError(f"solvent: {misplaced} are not fields of method 'lattice_boltzmann'")
    positive = {"minimum": 0, "exclusive_minimum": True}
    fields = {
        name: read_number(section, name, "solvent", **positive)
        for name in (
            "grid_spacing",
            "time_step",
            "mass_density",
            "kinematic_viscosity",
            "friction",
        )
    }
    fields["kinematic_bulk_viscosity"] = read_number(
        section, "kinematic_bulk_viscosity", "solvent", fields["kinematic_viscosity"], **positive
    )
    kT = read_number(section, "kT", "solvent", 1.0, minimum=0)
    noise = read_choice(section, "noise", "solvent", NOISE_LAWS, "uniform")
    a, tau, rho = fields["grid_spacing"], fields["time_step"], fields["mass_density"]
    mach_sq = 3 * kT * tau * tau / (rho * a**5)
    if mach_sq > MAX_THERMAL_MACH_NUMBER_SQ:
        raise ValueError(
            f"solvent: the thermal Mach number² kT/(mass_density a³ c_s²) = {mach_sq:.3g} "
            f"(c_s² = a²/(3 τ²)) exceeds {MAX_THERMAL_MACH_NUMBER_SQ}: node densities would "
            "fluctuate by more than a third and turn negative; reduce time_step or kT, or "
            "raise mass_density or grid_spacing"
        )
    return Solvent("lattice_boltzmann", kT=kT, noise=noise, **fields)


def lattice_nodes(lengths, grid_spacing: float) -> tuple[int, int, int]:
    """Nodes per box edge, n_α = L_α/a (whole numbers, checked by the scene)."""
    return tuple(round(length / grid_spacing) for length in lengths)


def _check_lattice(solvent: Solvent, lengths, integrator: Integrator) -> None:
    """Box edges whole multiples of the grid spacing, τ a whole multiple of Δt."""
    a = solvent.grid_spacing
    for axis, (length, n) in enumerate(zip(lengths, lattice_nodes(lengths, a), strict=True)):
        if n < 1 or not math.isclose(n * a, length, rel_tol=1e-9):
            raise ValueError(
                f"box.lengths: L_{'xyz'[axis]} = {length:.6g} is not a whole number of "
                f"solvent.grid_spacing = {a:.6g}; make every edge n a (e.g. "
                f"{max(1, n) * a:.6g})"
            )
    substeps = round(solvent.time_step / integrator.dt)
    if substeps < 1 or not math.isclose(substeps * integrator.dt, solvent.time_step, rel_tol=1e-9):
        raise ValueError(
            f"solvent.time_step = {solvent.time_step:.6g}: the LB time step must be a whole "
            f"number n ≥ 1 of MD steps integrator.dt = {integrator.dt:.6g} (e.g. "
            f"{max(1, substeps) * integrator.dt:.6g})"
        )


def _kind(section: Flow | BodyForce | None) -> str | None:
    return None if section is None else section.kind


def _read_flow(section, solvent: Solvent, neighbors: Neighbors) -> Flow | None:
    if section is None:
        return None
    check_keys(section, ("kind", *{f for fields in FLOW_FIELDS.values() for f in fields}), "flow")
    kind = read_choice(section, "kind", "flow", FLOW_KINDS)
    misplaced = sorted(set(section) - {"kind", *FLOW_FIELDS[kind]})
    if misplaced:
        raise ValueError(
            f"flow: {misplaced} do not belong to flow.kind = {kind!r}; its fields are "
            f"{list(FLOW_FIELDS[kind])}"
        )
    if solvent.method not in FLOW_SOLVENTS:
        raise ValueError(
            f"flow: solvent.method = {solvent.method!r} has no SLLOD integrator; use one "
            f"of {list(FLOW_SOLVENTS)} or remove the [flow] section"
        )
    if neighbors.method != "cell_list":
        raise ValueError(
            f"neighbors.method = {neighbors.method!r}: only the cell list knows the "
            "Lees–Edwards and Kraynik–Reinelt boundaries; use neighbors.method = "
            "'cell_list' with a [flow]"
        )
    if kind == "planar_elongation":
        if solvent.method not in ELONGATION_SOLVENTS:
            raise ValueError(
                f"flow: solvent.method = {solvent.method!r} has no Kraynik–Reinelt step; "
                f"planar elongation needs one of {list(ELONGATION_SOLVENTS)}"
            )
        return Flow(
            kind,
            elongation_rate=read_number(section, "elongation_rate", "flow"),
            kraynik_reinelt_case=read_number(
                section, "kraynik_reinelt_case", "flow", 1, minimum=1, maximum=4, integer=True
            ),
        )
    shear_rate = read_number(section, "shear_rate", "flow")
    frequency = read_number(
        section, "oscillation_frequency", "flow", None, minimum=0, exclusive_minimum=True
    )
    return Flow(kind, shear_rate, frequency)


def _read_body_force(section, solvent: Solvent, particles: Particles) -> BodyForce | None:
    if section is None:
        return None
    check_keys(section, ("kind", "amplitude", "waves", "species"), "body_force")
    if solvent.method != "dpd":
        raise ValueError(
            f"body_force: needs a thermostatted force-based solvent (solvent.method = 'dpd'), "
            f"not {solvent.method!r}"
        )
    kind = read_choice(section, "kind", "body_force", BODY_FORCE_KINDS)
    amplitude = read_number(section, "amplitude", "body_force")
    if kind == "cosine":
        if "species" in section:
            raise ValueError("body_force.species: only used with body_force.kind = 'tagged'")
        waves = read_number(section, "waves", "body_force", 1, minimum=1, integer=True)
        return BodyForce(kind, amplitude, waves)
    if "waves" in section:
        raise ValueError("body_force.waves: only used with body_force.kind = 'cosine'")
    species = read_string(section, "species", "body_force")
    counts = {s.name: s.count for s in particles.species}
    if species not in counts:
        raise ValueError(
            f"body_force.species = {species!r}: not a particle species; species are {list(counts)}"
        )
    if not 1 <= counts[species] < particles.count:
        raise ValueError(
            f"body_force.species = {species!r} has {counts[species]} particles: the tagged "
            "force needs at least one tagged and one untagged particle"
        )
    return BodyForce(kind, amplitude, species=species)


def _read_neighbors(section) -> Neighbors:
    check_keys(
        section, ("method", "format", "skin", "capacity_multiplier", "spring_skin"), "neighbors"
    )
    method = read_choice(section, "method", "neighbors", NEIGHBOR_METHODS, "cell_list")
    if method != "jax_md" and "format" in section:
        raise ValueError("neighbors.format: only used with neighbors.method = 'jax_md'")
    if method == "all_pairs" and "skin" in section:
        raise ValueError("neighbors.skin: the all_pairs list is never rebuilt; remove skin")
    return Neighbors(
        method=method,
        format=read_choice(section, "format", "neighbors", JAX_MD_FORMATS, "ordered_sparse"),
        skin=read_number(section, "skin", "neighbors", 0.0, minimum=0),
        capacity_multiplier=read_number(
            section, "capacity_multiplier", "neighbors", 1.25, minimum=1.0
        ),
        spring_skin=read_number(section, "spring_skin", "neighbors", 0.5, minimum=0),
    )


def _read_lengths(box_section):
    if "lengths" not in box_section:
        return None
    lengths = read_list(box_section, "lengths", "box")
    if len(lengths) != 3:
        raise ValueError(f"box.lengths: expected 3 edge lengths [Lx, Ly, Lz], got {lengths!r}")
    return tuple(
        read_number({"lengths": v}, "lengths", "box", minimum=0, exclusive_minimum=True)
        for v in lengths
    )


def _read_particles(section, lengths, chain_lengths: dict):
    if section is None:
        raise ValueError("particles: required section is missing (give density and/or count)")
    check_keys(section, ("density", "count", "species"), "particles")
    density = count = None
    if "density" in section:
        density = read_number(section, "density", "particles", minimum=0, exclusive_minimum=True)
    if "count" in section:
        count = read_number(
            section, "count", "particles", minimum=2, maximum=MAX_PARTICLES, integer=True
        )
    if lengths is not None:
        volume = math.prod(lengths)
        if not 0 < volume < math.inf:
            raise ValueError(
                f"box.lengths = {list(lengths)}: the volume {volume} is not a positive "
                "finite number (edges of a few r_c and more)"
            )
        if (density is None) == (count is None):
            raise ValueError(
                "particles: with box.lengths given, give exactly one of particles.density "
                "and particles.count"
            )
        if count is None:
            if not density * volume <= MAX_PARTICLES:
                raise ValueError(
                    f"particles.density = {density}: the box would hold {density * volume:.4g} "
                    f"particles, more than {MAX_PARTICLES} (int32 particle indices)"
                )
            count = round(density * volume)
            if count < 2:
                raise ValueError(
                    f"particles.density = {density}: the box holds {count} particles; need ≥ 2"
                )
        density = count / volume
    else:
        if density is None or count is None:
            raise ValueError(
                "particles: without box.lengths give both particles.density and "
                "particles.count (the box is then cubic)"
            )
        side = cube_root(count / density)
        if not math.isfinite(side):
            raise ValueError(
                f"particles.density = {density}: a cubic box of {count} particles at this "
                "density has no finite side; give a larger density"
            )
        lengths = (side, side, side)
        density = count / math.prod(lengths)
    species = _read_species(section.get("species", [{"name": "solvent"}]), count, chain_lengths)
    return Particles(count=count, density=density, species=species), lengths


def cube_root(volume: float) -> float:
    """The float nearest to volume^(1/3).

    `volume ** (1/3)` is often an ulp or two short (1000 ** (1/3) = 9.999999999999998)
    and `math.cbrt` can be an ulp off (cbrt(27) = 3.0000000000000004).  A box of
    N = 1000 ρ particles then has side 9.99… instead of 10, and its cell list 9
    cells of 1.11 r_c per axis instead of 10 of r_c: 1.11³ = 1.37 times the
    candidate pairs.  The neighbours of math.cbrt's result are compared exactly.
    """
    if not math.isfinite(volume) or volume <= 0:
        return volume ** (1.0 / 3.0)
    guess = math.cbrt(volume)
    candidates = (math.nextafter(guess, 0.0), guess, math.nextafter(guess, math.inf))
    return min(candidates, key=lambda side: abs(Fraction(side) ** 3 - Fraction(volume)))


def _read_species(entries, total: int, chain_lengths: dict) -> tuple[Species, ...]:
    """Species with resolved counts; a species chained into polymers of M beads gets
    a count that is a multiple of M (fractions are rounded to the nearest one)."""
    if not isinstance(entries, list) or not entries:
        raise TypeError("particles.species: expected a non-empty list of {name, count|fraction}")
    names, counts, fractions, masses = [], [], [], []
    for k, entry in enumerate(entries):
        path = f"particles.species[{k}]"
        check_keys(entry, ("name", "count", "fraction", "mass"), path)
        name = read_string(entry, "name", path)
        if name in names:
            raise ValueError(f"{path}.name = {name!r}: species names must be unique")
        if "count" in entry and "fraction" in entry:
            raise ValueError(f"{path}: give count or fraction, not both")
        names.append(name)
        counts.append(read_number(entry, "count", path, None, minimum=0, integer=True))
        fractions.append(read_number(entry, "fraction", path, None, minimum=0, maximum=1))
        masses.append(read_number(entry, "mass", path, 1.0, minimum=0, exclusive_minimum=True))
    if len(entries) == 1 and counts[0] is None and fractions[0] is None:
        return (Species(names[0], total, masses[0]),)
    if all(c is not None for c in counts):
        if sum(counts) != total:
            raise ValueError(
                f"particles.species: counts sum to {sum(counts)}, particles.count is {total}"
            )
        return tuple(Species(*entry) for entry in zip(names, counts, masses, strict=True))
    if all(f is not None for f in fractions):
        if not math.isclose(sum(fractions), 1.0, abs_tol=1e-9):
            raise ValueError(f"particles.species: fractions sum to {sum(fractions)}, must be 1")
        resolved = [
            chain_lengths.get(n, 1) * round(f * total / chain_lengths.get(n, 1))
            for n, f in zip(names[:-1], fractions[:-1], strict=True)
        ]
        resolved.append(total - sum(resolved))
        return tuple(Species(*entry) for entry in zip(names, resolved, masses, strict=True))
    raise ValueError("particles.species: give every species a count, or every one a fraction")


def _read_pair(section, solvent: Solvent, species) -> Pair | None:
    if section is None:
        return None
    if solvent.method == "hoogerbrugge_koelman":
        raise ValueError(
            "pair: the Hoogerbrugge–Koelman update carries its own conservative part "
            "(solvent.pi0); remove the [pair] section"
        )
    check_keys(section, ("kind", "a", "epsilon", "sigma"), "pair")
    kind = read_choice(section, "kind", "pair", PAIR_KINDS, "soft_repulsion")
    if kind == "wca":
        if "a" in section:
            raise ValueError("pair.a: belongs to kind 'soft_repulsion'; 'wca' takes epsilon, sigma")
        positive = {"minimum": 0, "exclusive_minimum": True}
        return Pair(
            kind,
            epsilon=read_number(section, "epsilon", "pair", **positive),
            sigma=read_number(section, "sigma", "pair", **positive),
        )
    misplaced = sorted({"epsilon", "sigma"} & set(section))
    if misplaced:
        raise ValueError(f"pair: {misplaced} belong to kind 'wca', not 'soft_repulsion'")
    names = [s.name for s in species]
    n = len(names)
    if "a" not in section:
        raise ValueError("pair.a: required field is missing (number, S×S list or species table)")
    a = section["a"]
    if isinstance(a, (int, float)) and not isinstance(a, bool):
        value = read_number(section, "a", "pair")
        matrix = [[value] * n for _ in range(n)]
    elif isinstance(a, dict):
        matrix = [[None] * n for _ in range(n)]
        for key in a:
            if not isinstance(key, str):
                raise TypeError(f"pair.a: key {key!r} must be a string 'A-B' of species names")
            parts = key.split("-")
            if len(parts) != 2:
                raise ValueError(f"pair.a: key {key!r} must be 'A-B' with two species names")
            for part in parts:
                if part not in names:
                    raise ValueError(f"pair.a: unknown species {part!r}; species are {names}")
            p, q = names.index(parts[0]), names.index(parts[1])
            number = read_number(a, key, "pair.a")
            for x, y in ((p, q), (q, p)):
                if matrix[x][y] is not None and matrix[x][y] != number:
                    raise ValueError(f"pair.a: {key!r} given twice with different values")
                matrix[x][y] = number
        missing = [
            f"{names[p]}-{names[q]}" for p in range(n) for q in range(p, n) if matrix[p][q] is None
        ]
        if missing:
            raise ValueError(f"pair.a: missing entries {missing}")
    elif isinstance(a, list):
        if len(a) != n or any(not isinstance(row, list) or len(row) != n for row in a):
            raise ValueError(f"pair.a: expected a {n}×{n} matrix (species {names}), got {a!r}")
        matrix = [[read_number({"a": v}, "a", "pair") for v in row] for row in a]
        for p in range(n):
            for q in range(p + 1, n):
                if matrix[p][q] != matrix[q][p]:
                    raise ValueError(
                        f"pair.a: must be symmetric; a[{p}][{q}] = {matrix[p][q]} but "
                        f"a[{q}][{p}] = {matrix[q][p]}"
                    )
    else:
        raise TypeError(f"pair.a: expected a number, list or table, got {type(a).__name__}")
    return Pair(kind, tuple(tuple(row) for row in matrix))


def _wca_cutoff(data: dict, pair: Pair) -> float:
    """The cut-off of a WCA scene: 2^(1/6) σ; a given `cutoff` must equal it."""
    wca_range = 2 ** (1 / 6) * pair.sigma
    if "cutoff" in data and not math.isclose(data["cutoff"], wca_range, rel_tol=1e-9):
        raise ValueError(
            f"cutoff = {data['cutoff']!r}: with pair.kind = 'wca' the cut-off is the WCA "
            f"range 2^(1/6) sigma = {wca_range:.6g}; remove cutoff"
        )
    return wca_range


BOND_PARAMETERS = {
    "hookean": {"spring_constant": REQUIRED},
    "fraenkel": {"spring_constant": REQUIRED, "rest_length": REQUIRED},
    "harmonic": {"spring_constant": REQUIRED, "rest_length": REQUIRED},
    "fene": {"spring_constant": REQUIRED, "max_extension": REQUIRED},
    "fene_log_wca": {
        "spring_constant": REQUIRED,
        "max_extension": REQUIRED,
        "wca_epsilon": 1.0,
        "wca_sigma": 1.0,
    },
}


def _polymer_entries(entries) -> list:
    if not isinstance(entries, list):
        raise TypeError(
            f"polymers: expected a list of tables ([[polymers]] in TOML), got "
            f"{type(entries).__name__}"
        )
    for k, entry in enumerate(entries):
        check_keys(entry, ("species", "beads", "bond"), f"polymers[{k}]")
    return entries


def _read_polymers(entries: list, species) -> tuple[Polymer, ...]:
    counts = {s.name: s.count for s in species}
    polymers, used = [], set()
    for k, entry in enumerate(entries):
        path = f"polymers[{k}]"
        name = read_string(entry, "species", path)
        if name not in counts:
            raise ValueError(
                f"{path}.species = {name!r}: not a particle species; species are {list(counts)}"
            )
        if name in used:
            raise ValueError(f"{path}.species = {name!r}: already chained by another entry")
        used.add(name)
        beads = read_number(entry, "beads", path, minimum=2, integer=True)
        if counts[name] == 0 or counts[name] % beads:
            raise ValueError(
                f"particles.species {name!r}: {counts[name]} particles do not make whole "
                f"chains of {path}.beads = {beads}; give a count that is a positive multiple "
                f"of {beads}"
            )
        bond = _read_bond(entry.get("bond"), f"{path}.bond")
        polymers.append(Polymer(name, beads, tuple(bond.items())))
    return tuple(polymers)


def _read_bond(section, path: str) -> dict:
    """The bond table."""
    if section is None:
        raise ValueError(f"{path}: required table is missing; law: {list(BOND_PARAMETERS)}")
    check_keys(section, ("law", *{k for p in BOND_PARAMETERS.values() for k in p}), path)
    law = read_choice(section, "law", path, tuple(BOND_PARAMETERS))
    defaults = BOND_PARAMETERS[law]
    misplaced = sorted(set(section) - {"law", *defaults})
    if misplaced:
        raise ValueError(f"{path}: {misplaced} are not parameters of law {law!r}")
    bond = {"law": law}
    for key, default in defaults.items():
        strictly_positive = key != "rest_length" and key != "wca_epsilon"
        bond[key] = read_number(
            section, key, path, default, minimum=0, exclusive_minimum=strictly_positive
        )
    if law == "fene_log_wca" and not 2 ** (1 / 6) * bond["wca_sigma"] < bond["max_extension"]:
        raise ValueError(
            f"{path}: the WCA range 2^(1/6) wca_sigma = {2 ** (1 / 6) * bond['wca_sigma']:.4g} "
            f"must be below max_extension = {bond['max_extension']}"
        )
    return bond


def _read_integrator(section, solvent: Solvent) -> Integrator:
    section = section if section is not None else {}
    check_keys(section, ("dt", "lambda"), "integrator")
    if solvent.method == "lowe_andersen" and "lambda" in section:
        raise ValueError(
            "integrator.lambda: the Lowe–Andersen step has no velocity-dependent force, so "
            "the λ of Groot and Warren's modified velocity Verlet plays no role; remove it"
        )
    if solvent.method == "lattice_boltzmann" and "lambda" in section:
        raise ValueError(
            "integrator.lambda: the beads in a lattice-Boltzmann solvent move by velocity "
            "Verlet around the friction step (no λ); remove it"
        )
    default_dt = {
        "hoogerbrugge_koelman": 1.0,
        "lattice_boltzmann": solvent.time_step,
        "mpcd": solvent.collision_time,
    }.get(solvent.method, 0.04)
    dt = read_number(section, "dt", "integrator", default_dt, minimum=0, exclusive_minimum=True)
    lam = read_number(section, "lambda", "integrator", 0.5, minimum=0, maximum=1)
    if solvent.method == "mpcd":
        h = solvent.collision_time
        substeps = round(h / dt)
        if substeps < 1 or abs(substeps * dt - h) > 1e-9 * h:
            raise ValueError(
                f"integrator.dt = {dt!r}: the monomer sub-step h_p must divide "
                f"solvent.collision_time h = {h!r} a whole number of times (h/h_p = "
                f"{h / dt:.6g}); e.g. dt = {h / max(1, math.ceil(h / dt)):.6g}"
            )
        if lam != 0.5:
            raise ValueError(
                f"integrator.lambda = {lam!r}: MPCD monomers move by plain velocity "
                "Verlet (λ = 0.5; Mussawisade et al. §II); remove integrator.lambda"
            )
    return Integrator(dt=dt, lambda_=lam)


def _check_mpcd(solvent: Solvent, lengths, species, polymers, pair) -> None:
    """Cross-section checks of an MPCD scene (module docstring)."""
    collision_grid(lengths, solvent.cell_size)
    chained = {p.species for p in polymers}
    names = [s.name for s in species]
    positions = [k for k, name in enumerate(names) if name in chained]
    if positions and positions[-1] - positions[0] + 1 != len(positions):
        raise ValueError(
            f"particles.species: with solvent.method = 'mpcd' the chained species "
            f"{sorted(chained)} must be adjacent in the species list (monomers form one "
            f"index range); reorder {names}"
        )
    if solvent.collision == "particle" and set(names) != chained:
        free = [name for name in names if name not in chained]
        raise ValueError(
            f"solvent.collision = 'particle' is the solvent-free Rouse variant (every "
            f"monomer's velocity rotated alone); species {free} are not chained: give "
            "them [[polymers]] entries, remove them, or use collision = 'cell'"
        )
    if pair is not None and not chained:
        raise ValueError(
            "pair: with solvent.method = 'mpcd' pair forces act among the [[polymers]] "
            "species only (solvent particles feel no forces); add [[polymers]] or remove "
            "the [pair] section"
        )


def _read_run(section) -> Run:
    check_keys(section, ("steps", "chunk", "equilibration"), "run")
    return Run(
        steps=read_number(section, "steps", "run", 1000, minimum=0, integer=True),
        chunk=read_number(section, "chunk", "run", 100, minimum=1, integer=True),
        equilibration=read_number(section, "equilibration", "run", 0, minimum=0, integer=True),
    )


def _read_output(section, chunk: int, solvent: Solvent, cutoff: float) -> Output:
    settings = [setting for component in OBSERVABLES for setting in component.settings]
    check_keys(
        section,
        (
            "path",
            "observables",
            "trajectory_every",
            "checkpoint_every",
            "checkpoint_seconds",
            *(setting.name for setting in settings),
        ),
        "output",
    )
    lattice = solvent.method == "lattice_boltzmann"
    default = ["temperature"] if lattice else ["temperature", "pressure"]
    observables = read_list(section, "observables", "output", default)
    if lattice and "pressure" in observables:
        raise ValueError(
            "output.observables: 'pressure' of a lattice-Boltzmann scene would need the "
            "fluid's stress, which is not measured; remove it"
        )
    for name in observables:
        OBSERVABLES.get(name)
    every = {}
    for key, what in (("trajectory_every", "frames"), ("checkpoint_every", "checkpoints")):
        every[key] = read_number(section, key, "output", 0, minimum=0, integer=True)
        if every[key] % chunk:
            raise ValueError(
                f"output.{key} = {every[key]}: {what} are written at chunk ends, so it "
                f"must be a multiple of run.chunk = {chunk} (or 0 for none)"
            )
    return Output(
        path=read_string(section, "path", "output", None),
        observables=tuple(dict.fromkeys(observables)),
        **every,
        checkpoint_seconds=read_number(section, "checkpoint_seconds", "output", 300.0, minimum=0),
        settings=tuple((setting.name, setting.read(section, cutoff)) for setting in settings),
    )


def _check_observables(scene: Scene) -> None:
    """Each listed observable's requirements (jaxdpd.observables.component)."""
    accumulating = []
    for name in scene.output.observables:
        component = OBSERVABLES.get(name)
        if component.needs_polymers and not scene.polymers:
            raise SceneError(
                "output.observables",
                f"{name!r} measures polymers; add a [[polymers]] section or remove it",
            )
        component.check(scene)
        if component.accumulates:
            accumulating.append(name)
    if len(accumulating) > 1:
        raise SceneError(
            "output.observables",
            f"{accumulating} each keep on-device accumulators (SimState.observers holds "
            "one observable's); list one of them per run",
        )


SPRING_REPULSION_PARAMETERS = {
    "exponential": {"A": 100.0, "alpha": 10.0},
    "linear": {"a": REQUIRED},
}


def _read_spring_repulsion(section, polymers, cutoff: float) -> SpringRepulsion | None:
    if section is None:
        return None
    path = "spring_repulsion"
    keys = {k for p in SPRING_REPULSION_PARAMETERS.values() for k in p}
    check_keys(section, ("law", *keys, "range", "distance_floor"), path)
    if not polymers:
        raise ValueError(
            f"{path}: acts between the springs of chains; add a [[polymers]] section or remove it"
        )
    law = read_choice(section, "law", path, SPRING_REPULSION_LAWS, "exponential")
    defaults = SPRING_REPULSION_PARAMETERS[law]
    misplaced = sorted(keys & set(section) - set(defaults))
    if misplaced:
        raise ValueError(f"{path}: {misplaced} are not parameters of law {law!r}")
    parameters = tuple(
        (key, read_number(section, key, path, default, minimum=0, exclusive_minimum=True))
        for key, default in defaults.items()
    )
    reach = read_number(section, "range", path, cutoff / 3, minimum=0, exclusive_minimum=True)
    floor = read_number(section, "distance_floor", path, 0.001 * cutoff, minimum=0)
    if not floor < reach:
        raise ValueError(f"{path}.distance_floor = {floor}: must be below {path}.range = {reach}")
    return SpringRepulsion(law, parameters, reach, floor)


def _check_spring_room(polymers, spring_room: tuple[float, str, str]) -> None:
    """Refuse a finitely extensible spring that may grow past half the box.

    Args:
        polymers: the scene's Polymers.
        spring_room: (twice the longest spring the box allows, what that length is,
            its reference).
    """
    room, room_name, reference = spring_room
    for k, polymer in enumerate(polymers):
        extension = polymer.bond_parameters.get("max_extension")
        if extension is not None and not extension < room / 2:
            raise ValueError(
                f"polymers[{k}].bond.max_extension = {extension}: a spring must stay "
                f"shorter than half {room_name} ({room / 2:.4g}; {reference}) where it "
                "is read by minimum image (a flowing box, spring_repulsion, the "
                "'spring_pairs' observable); enlarge the box or shorten the spring"
            )


def _check_spring_reach(spring_repulsion, output: Output, neighbors: Neighbors, heights):
    """Spring pairs are listed by midpoints within ℓ + reach + skin (ℓ: the longest
    spring), which must stay below half the box's thinnest height: refuse a reach and
    skin that leave no room for springs."""
    reaches = []
    if spring_repulsion is not None:
        reaches.append(("spring_repulsion.range", spring_repulsion.range))
    if "spring_pairs" in output.observables:
        reaches.append(("output.spring_pair_max", output.spring_pair_max))
    if not reaches:
        return
    name, reach = max(reaches, key=lambda item: item[1])
    half_height = 0.5 * min(heights)
    if not reach + neighbors.spring_skin < half_height:
        raise ValueError(
            f"{name} = {reach}: with neighbors.spring_skin = {neighbors.spring_skin} it must "
            f"leave room for the springs below half the box's thinnest height "
            f"({half_height:.4g}; spring pairs are listed by midpoints within spring length "
            "+ range + skin); enlarge the box or reduce them"
        )
