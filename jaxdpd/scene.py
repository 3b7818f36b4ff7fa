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
                needs a Lees–Edwards box and a solvent method with a shear step
                (every method; docs/solvent_flows/README.md has the table)
                kind = "planar_elongation": elongation_rate ε̇ (1/time, any sign;
                u = ε̇ (−(x − x0), 0, z − z0), thesis eq. 5.12), kraynik_reinelt_case
                = 1..4 (lattice of thesis table 3.27, default 1); needs a
                Kraynik–Reinelt box and a solvent method with an elongation step
                (every method but "lattice_boltzmann")
    [particles] density ρ > 0 and/or count N ≥ 2; species = [{name, count|fraction,
                mass}] (mass > 0 in units of m, default 1)
                with box.lengths give one of density/count; without, give both
                (cubic box of side (N/ρ)^(1/3))
    [solvent]   method = a registered solvent method (jaxdpd.solvents.SOLVENTS):
                "dpd" (Groot–Warren), "hoogerbrugge_koelman", "lowe_andersen",
                "lattice_boltzmann", "mpcd"; each method's module documents its
                fields, defaults and ranges (jaxdpd.solvents.groot_warren,
                .hoogerbrugge_koelman, .lowe_andersen, .lattice_boltzmann.method,
                .mpcd.method) and states which flows, pair and body forces and
                observables it supports (jaxdpd.solvents.component)
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
    [integrator] dt > 0 (default 0.04, or the solvent method's: 1 for
                hoogerbrugge_koelman, solvent.time_step for lattice_boltzmann,
                solvent.collision_time for mpcd); lambda in [0, 1] (not a field of
                lowe_andersen and lattice_boltzmann, whose steps have no
                velocity-dependent force to predict)
    [neighbors] method = "cell_list" | "jax_md" | "all_pairs" (every pair, fixed: for
                small systems such as one chain); format (jax_md) = "dense" |
                "sparse" | "ordered_sparse"; skin ≥ 0; capacity_multiplier ≥ 1;
                spring_skin ≥ 0 (default 0.5: skin of the spring-pair list, used with
                [spring_repulsion] or the "spring_pairs" observable)
    [parallel]  devices ≥ 1 (one system cut into that many slabs, one per device;
                jaxdpd.decomposition, docs/scaling_out.md); axis = "x" | "y" | "z"
                (default: the box's longest edge it may cut: y in flow); margin ≥ 0
                (default 0.8 r_c: added to the reach for the halo)
    [run]       steps ≥ 0, chunk ≥ 1, equilibration ≥ 0 (steps run before sampling)
    [output]    path (H5MD file, optional); observables ⊂ {"temperature",
                "pressure", "rdf", "conformation", "dynamics", "profile",
                "transverse_current", "drag" (needs body_force.kind = "tagged"),
                "spring_pairs"} (default temperature and pressure, less those the
                solvent method cannot provide: no pressure with lattice_boltzmann);
                rdf_bins, rdf_max; profile_bins ≥ 1 (slabs along y);
                spring_pair_bins ≥ 1, spring_pair_max > 0 (default r_c/3: histogram of
                spring closest approaches, and spring crossings; needs [[polymers]]);
                trajectory_every (0 = never); correlator_every ≥ 1 (steps between
                samples of the "dynamics" correlators), correlator_levels ≥ 1;
                current_modes ≥ 1 (transverse currents at k = 2πn/L, n = 1 ..
                current_modes; cubic boxes); checkpoint_every (steps, 0 = none
                by step count); checkpoint_seconds ≥ 0 (wall-clock seconds between
                checkpoints, default 300, 0 = none by time); checkpoints are also
                written at the end, on errors and on SIGINT/SIGTERM; trajectory_every
                and checkpoint_every are multiples of run.chunk; author (the H5MD
                author name, default the OS login)
    [initial]   file = a GSD, extended XYZ or LAMMPS data file to start from (its
                positions, and velocities where it holds them; jaxdpd.io.initial);
                frame = index of the frame to take (default −1, the last); format =
                "gsd" | "xyz" | "lammps-data" (default: from the file's extension);
                particle counts, species and bonds must match the scene; not with
                box.kind = "kraynik_reinelt"
"""

import json
import math
import tomllib
from dataclasses import asdict, dataclass, field
from fractions import Fraction

from jaxdpd.decomposition.requirements import check_scene as check_decomposition
from jaxdpd.forces.bonds import read_bond
from jaxdpd.forces.pair_laws import PAIR_LAWS, Pair, read_pair
from jaxdpd.forces.spring_repulsion import SPRING_REPULSION_LAWS
from jaxdpd.geometry.boxes import BOXES, box_for_flow, make_box
from jaxdpd.observables import OBSERVABLES
from jaxdpd.solvents import SOLVENTS, SolventMethod, SolventParameters
from jaxdpd.validation import (
    REQUIRED,
    SceneError,
    as_scene_error,
    check_keys,
    read_choice,
    read_list,
    read_number,
    read_string,
)

PRECISIONS = ("float32", "float64")
NEIGHBOR_METHODS = ("cell_list", "jax_md", "all_pairs")
JAX_MD_FORMATS = ("dense", "sparse", "ordered_sparse")
FLOW_KINDS = ("shear", "planar_elongation")
# What a solvent method lacks that does not support a flow kind (in messages).
FLOW_STEPS = {"shear": "Lees–Edwards step", "planar_elongation": "Kraynik–Reinelt step"}
# The fields of each flow kind in the [flow] section.
FLOW_FIELDS = {
    "shear": ("shear_rate", "oscillation_frequency"),
    "planar_elongation": ("elongation_rate", "kraynik_reinelt_case"),
}
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
class Parallel:
    """[parallel]: one system decomposed over devices (jaxdpd.decomposition).

    devices: slabs, one per device (1: the whole system on one device); axis: the
    frame axis cut into slabs ("x", "y", "z"; None: the box's default); margin: how
    far two particles may approach each other within one step beyond the
    interaction reach (r_c), which widens the halo.
    """

    devices: int = 1
    axis: str | None = None
    margin: float = 0.8


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
    author: str | None = None

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
        if self.author is not None:
            data["author"] = self.author
        return data


@dataclass(frozen=True)
class Initial:
    """[initial]: start from a configuration file (jaxdpd.io.initial).

    file: its path; frame: the frame to take (negative: from the end); format: the
    file format's name (jaxdpd.io.formats.FILE_FORMATS).
    """

    file: str
    frame: int = -1
    format: str = "gsd"


@dataclass(frozen=True)
class Scene:
    """A complete, validated simulation description (see the module docstring)."""

    seed: int
    precision: str
    cutoff: float
    box: Box
    particles: Particles
    solvent: SolventParameters
    pair: Pair | None
    integrator: Integrator
    polymers: tuple[Polymer, ...] = ()
    flow: Flow | None = None
    body_force: BodyForce | None = None
    spring_repulsion: SpringRepulsion | None = None
    neighbors: Neighbors = field(default_factory=Neighbors)
    parallel: Parallel = field(default_factory=Parallel)
    run: Run = field(default_factory=Run)
    output: Output = field(default_factory=Output)
    initial: Initial | None = None

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
        """Validate a scene dictionary.

        Raises:
            SceneError: a ValueError (SceneTypeError: also a TypeError) whose message
                names the field and the valid range, and whose `field` is the field's
                dotted path, whichever component's reader or check refused it.
        """
        try:
            return cls._assemble(data)
        except (ValueError, TypeError) as error:
            raise as_scene_error(error) from None

    @classmethod
    def _assemble(cls, data: dict) -> "Scene":
        """Read every section and run the checks across them (see from_dict)."""
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
                "parallel",
                "run",
                "output",
                "initial",
            ),
            "scene",
        )
        seed = read_number(data, "seed", "", 0, minimum=0, maximum=2**32 - 1, integer=True)
        precision = read_choice(data, "precision", "", PRECISIONS, "float32")
        cutoff = read_number(data, "cutoff", "", 1.0, minimum=0, exclusive_minimum=True)
        if "solvent" not in data:
            raise ValueError(
                f"solvent: required section is missing; method: {list(SOLVENTS.names())}"
            )
        solvent = _read_solvent(data["solvent"])
        method = SOLVENTS.get(solvent.method)
        neighbors = _read_neighbors(data.get("neighbors", {}))
        flow = _read_flow(data.get("flow"), method, neighbors)
        box_section = data.get("box", {})
        check_keys(box_section, ("kind", "lengths"), "box")
        flow_box = box_for_flow(_kind(flow))
        box_kind = read_choice(box_section, "kind", "box", BOXES.names(), flow_box)
        if box_kind != flow_box:
            raise ValueError(
                f"box.kind = {box_kind!r} does not fit flow.kind = {_kind(flow)!r}: "
                f"that flow needs box.kind = {flow_box!r} (or leave box.kind out)"
            )
        lengths = _read_lengths(box_section)
        polymer_entries = _polymer_entries(data.get("polymers", []))
        chain_lengths = {
            entry["species"]: entry["beads"]
            for entry in polymer_entries
            if isinstance(entry.get("species"), str) and isinstance(entry.get("beads"), int)
        }
        particles, lengths = _read_particles(data.get("particles"), lengths, chain_lengths)
        if data.get("pair") is not None and not method.pair_forces:
            _refuse_section("pair", method, "pair_forces")
        pair = None if data.get("pair") is None else read_pair(data["pair"], particles.species)
        if pair is not None:
            cutoff = PAIR_LAWS.get(pair.kind).cutoff(pair, cutoff, data.get("cutoff"))
        range_name, pair_range = method.pair_range(solvent, cutoff)
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
        integrator = _read_integrator(data.get("integrator"), method, solvent)
        polymers = _read_polymers(polymer_entries, particles.species)
        run = _read_run(data.get("run", {}))
        output = _read_output(data.get("output", {}), run.chunk, method, cutoff)
        spring_repulsion = _read_spring_repulsion(data.get("spring_repulsion"), polymers, cutoff)
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
        if data.get("body_force") is not None and not method.body_forces:
            _refuse_section("body_force", method, "body_forces")
        body_force = _read_body_force(data.get("body_force"), particles)
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
            parallel=_read_parallel(data.get("parallel", {})),
            run=run,
            output=output,
            initial=_read_initial(data.get("initial"), box_kind),
        )
        method.check(scene)
        _check_observables(scene)
        if scene.parallel.devices > 1:
            check_decomposition(scene)
        return scene

    # -- derived quantities --------------------------------------------------------
    @property
    def n_particles(self) -> int:
        """Total number of particles N."""
        return self.particles.count

    @property
    def solvent_component(self) -> SolventMethod:
        """The component of the solvent method (jaxdpd.solvents.SOLVENTS)."""
        return SOLVENTS.get(self.solvent.method)

    @property
    def step_time(self) -> float:
        """Simulated time per step: integrator.dt, or the solvent method's (the
        collision time h of an MPCD solvent, whose monomer sub-steps integrator.dt run
        inside the step)."""
        return self.solvent_component.step_time(self)

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
        return self.solvent_component.conserves_particle_momentum

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
        if not self.solvent_component.integrator_lambda:
            del data["integrator"]["lambda"]
        data["box"]["lengths"] = list(self.box.lengths)
        data["particles"] = {
            "count": self.particles.count,
            "species": [
                {"name": s.name, "count": s.count, "mass": s.mass} for s in self.particles.species
            ],
        }
        data["solvent"] = self.solvent_component.to_dict(self.solvent)
        if self.pair is None:
            del data["pair"]
        else:
            data["pair"] = PAIR_LAWS.get(self.pair.kind).to_dict(self.pair)
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
        if self.initial is None:
            del data["initial"]
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
        if self.parallel.devices == 1:
            del data["parallel"]
        elif self.parallel.axis is None:
            del data["parallel"]["axis"]
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


def _read_solvent(section) -> SolventParameters:
    """The [solvent] section, read by the component its method names; fields of other
    methods are an error naming their owner, not ignored."""
    fields = {method.name: method.fields for method in SOLVENTS}
    check_keys(section, ("method", "kT", *(f for own in fields.values() for f in own)), "solvent")
    if "method" not in section:
        raise SceneError(
            "solvent.method", f"required field is missing; valid: {list(SOLVENTS.names())}"
        )
    method = SOLVENTS.get(section["method"])
    solvent = method.read(section)  # its own messages for common mistakes first
    own = set(method.fields)
    for owner, owned in fields.items():
        misplaced = sorted((set(owned) - own) & set(section))
        if owner != method.name and misplaced:
            raise ValueError(
                f"solvent: {misplaced} belong to method {owner!r}, not {method.name!r}"
            )
    return solvent


def _refuse_section(name: str, method: SolventMethod, capability: str) -> None:
    """A [pair] or [body_force] section the solvent method has no place for
    (`capability`: the SolventMethod attribute that allows it)."""
    able = [m.name for m in SOLVENTS if getattr(m, capability)]
    raise ValueError(
        f"{name}: solvent.method = {method.name!r} takes no [{name}] (methods that do: "
        f"{able}); remove the [{name}] section"
    )


def _kind(section: Flow | BodyForce | None) -> str | None:
    return None if section is None else section.kind


def _read_flow(section, method: SolventMethod, neighbors: Neighbors) -> Flow | None:
    """The [flow] section; `method` is the solvent component, which must support it."""
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
    if kind not in method.flows:
        able = [m.name for m in SOLVENTS if kind in m.flows]
        missing = FLOW_STEPS[kind] if method.flows else "SLLOD integrator"
        raise ValueError(
            f"flow.kind = {kind!r}: solvent.method = {method.name!r} supports "
            f"{list(method.flows)} (no {missing}); use one of {able} or remove the [flow] "
            "section"
        )
    if neighbors.method != "cell_list":
        raise ValueError(
            f"neighbors.method = {neighbors.method!r}: only the cell list knows the "
            "Lees–Edwards and Kraynik–Reinelt boundaries; use neighbors.method = "
            "'cell_list' with a [flow]"
        )
    if kind == "planar_elongation":
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


def _read_body_force(section, particles: Particles) -> BodyForce | None:
    if section is None:
        return None
    check_keys(section, ("kind", "amplitude", "waves", "species"), "body_force")
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
        bond = read_bond(entry.get("bond"), f"{path}.bond")
        polymers.append(Polymer(name, beads, tuple(bond.items())))
    return tuple(polymers)


def _read_integrator(section, method: SolventMethod, solvent: SolventParameters) -> Integrator:
    """dt (default the solvent method's) and λ, with the method's rules on both."""
    section = section if section is not None else {}
    check_keys(section, ("dt", "lambda"), "integrator")
    default_dt = method.default_dt(solvent)
    dt = read_number(section, "dt", "integrator", default_dt, minimum=0, exclusive_minimum=True)
    lam = read_number(section, "lambda", "integrator", 0.5, minimum=0, maximum=1)
    integrator = Integrator(dt=dt, lambda_=lam)
    method.check_integrator(solvent, section, integrator)
    return integrator


def _read_parallel(section) -> Parallel:
    check_keys(section, ("devices", "axis", "margin"), "parallel")
    return Parallel(
        devices=read_number(section, "devices", "parallel", 1, minimum=1, integer=True),
        axis=read_choice(section, "axis", "parallel", ("x", "y", "z"), None),
        margin=read_number(section, "margin", "parallel", 0.8, minimum=0),
    )


def _read_run(section) -> Run:
    check_keys(section, ("steps", "chunk", "equilibration"), "run")
    return Run(
        steps=read_number(section, "steps", "run", 1000, minimum=0, integer=True),
        chunk=read_number(section, "chunk", "run", 100, minimum=1, integer=True),
        equilibration=read_number(section, "equilibration", "run", 0, minimum=0, integer=True),
    )


def _read_output(section, chunk: int, method: SolventMethod, cutoff: float) -> Output:
    settings = [setting for component in OBSERVABLES for setting in component.settings]
    check_keys(
        section,
        (
            "path",
            "observables",
            "trajectory_every",
            "checkpoint_every",
            "checkpoint_seconds",
            "author",
            *(setting.name for setting in settings),
        ),
        "output",
    )
    unavailable = method.unavailable_observables  # of the solvent method
    default = [name for name in ("temperature", "pressure") if name not in unavailable]
    observables = read_list(section, "observables", "output", default)
    for name, reason in unavailable.items():
        if name in observables:
            raise ValueError(f"output.observables: {name!r} {reason}; remove it")
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
        author=read_string(section, "author", "output", None),
    )


def _read_initial(section, box_kind: str) -> Initial | None:
    """The [initial] section: the file, its frame and format (read when the run
    starts, jaxdpd.io.initial, so a stored scene reloads without the file)."""
    if section is None:
        return None
    from jaxdpd.io.formats import format_of  # io reads scenes: imported when used

    check_keys(section, ("file", "frame", "format"), "initial")
    if box_kind == "kraynik_reinelt":
        raise ValueError(
            "initial: a Kraynik–Reinelt box starts from its own tilted cell; starting "
            "from a file is supported in periodic and Lees–Edwards boxes (remove [initial])"
        )
    file = read_string(section, "file", "initial")
    frame = read_number(section, "frame", "initial", -1, minimum=-(2**31), integer=True)
    name = read_string(section, "format", "initial", None)
    return Initial(file, frame, format_of(file, name).name)


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
