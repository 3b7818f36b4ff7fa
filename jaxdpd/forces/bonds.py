"""Bond laws of bead-spring polymers and the bonded force on linear chains.

Each law is a scalar law in the squared spring length q² = |Q|²: its `stiffness`
T(Q)/Q (tension per unit length, positive = the spring pulls its beads together)
and its `energy` U(Q).  The force on bead k of the spring Q = r_{k+1} − r_k is
+(T/Q) Q and on bead k+1 it is −(T/Q) Q, so T = dU/dQ.  Working in q² avoids a
square root for the Hookean and FENE laws and keeps the laws smooth at Q = 0.

Laws (H, K, k: spring constants in k_BT/r_c²; Q0, R0, r_eq, σ: lengths in r_c):
    hookean       T = H Q,  U = ½ H Q²                            (thesis eq. 2.25)
    fraenkel      T = K (Q − r_eq),  U = ½ K (Q − r_eq)²           (a harmonic bond with
                  rest length; Mussawisade et al. eq. 4 with κ = K, l = r_eq)
    harmonic      the same law under the name MD codes use (note LAMMPS's
                  `bond_style harmonic` writes U = K (r − r0)², i.e. its K is ½ of ours)
    fene          T = H Q / (1 − Q²/Q0²),
                  U = −½ H Q0² ln(1 − Q²/Q0²)              (Warner; thesis eqs. 2.26, 4.2)
    fene_log_wca  U = −½ k R0² ln(1 − Q²/R0²) + 4ε[(σ/Q)¹² − (σ/Q)⁶ + ¼] for Q < 2^{1/6}σ
                  (Kremer–Grest; Ahlrichs & Dünweg eq. 8), the WCA part acting between
                  the bonded beads (as in LAMMPS `bond_style fene`)

Each law is one `BondLaw` component, registered in `BOND_LAWS` under the name a
scene's `[[polymers]].bond.law` gives: it owns its parameters (names, defaults,
ranges), its checks, its force and energy, its maximum extension and the bond length
chains are built with.  The same law objects serve the Brownian dumbbells of
jaxdpd.brownian.springs, there with H = 1 in the units of the dumbbell (thesis
eq. 4.10).

A FENE spring cannot reach Q0: where a step takes it there the stiffness is
evaluated at a floor of the denominator (finite), and `overstretched` reports it so
that the driver stops with a message instead of producing NaNs.

A law's stiffness and energy are pure functions of q² and its named parameters, so
the parameters may also be traced arrays: `Bond.with_parameters` binds values taken
from `SimState.parameters` inside a step (one compiled step for every spring
constant; vmap over parameter sets; derivatives with respect to a parameter).
"""

import dataclasses
import functools
import math
from collections.abc import Callable
from dataclasses import dataclass

import jax.numpy as jnp

from jaxdpd.dyadic import dyadic_sum
from jaxdpd.forces.pair_laws import WCA_RANGE_FACTOR, wca_energy, wca_force_over_distance
from jaxdpd.registry import Registry
from jaxdpd.validation import REQUIRED, check_keys, read_choice, read_number

# 1 − Q²/Q0² is floored here when a FENE spring is at or past Q0 (the step is
# flagged and the run stops at the end of the chunk).
FENE_DENOMINATOR_FLOOR = 1e-6


@dataclass(frozen=True)
class Parameter:
    """A parameter of a bond law in the scene's bond table.

    Attributes:
        default: its value when the table leaves it out (REQUIRED: none).
        strictly_positive: the value must be > 0 (else ≥ 0).
    """

    default: object = REQUIRED
    strictly_positive: bool = True


class BondLaw:
    """A bond law: a component named by `polymers[].bond.law`.

    Subclasses set `parameters` (name → Parameter, in the order of the resolved
    scene's bond table) and define `stiffness`, `energy` and `placement_length`;
    finitely extensible laws also `max_extension`, and laws with cross-field
    conditions `check`.
    """

    name: str
    parameters: dict[str, Parameter]

    def stiffness(self, q_sq, **values):
        """T/Q at squared length `q_sq` (elementwise, any float array)."""
        raise NotImplementedError

    def energy(self, q_sq, **values):
        """U at squared length `q_sq` (elementwise; for tests and diagnostics)."""
        raise NotImplementedError

    def max_extension(self, values: dict):
        """The length a spring cannot reach (Q0, R0), or None for laws without one."""
        return None

    def placement_length(self, values: dict, kT: float) -> float:
        """A bond length to build chains with: where the energy is lowest if that is
        away from zero, else the root-mean-square length of a free spring at k_BT."""
        raise NotImplementedError

    def check(self, values: dict, path: str) -> None:
        """Conditions between the parameters (none by default)."""

    def read(self, section: dict, path: str) -> dict:
        """The resolved bond table {"law": name, parameter: value, ...} of `section`.

        Args:
            section: the scene's bond table (keys already checked to be parameters
                of some law).
            path: its dotted path ("polymers[0].bond"), for messages.
        """
        misplaced = sorted(set(section) - {"law", *self.parameters})
        if misplaced:
            raise ValueError(f"{path}: {misplaced} are not parameters of law {self.name!r}")
        values = {
            key: read_number(
                section,
                key,
                path,
                parameter.default,
                minimum=0,
                exclusive_minimum=parameter.strictly_positive,
            )
            for key, parameter in self.parameters.items()
        }
        self.check(values, path)
        return {"law": self.name, **values}

    def bind(self, values: dict, kT: float) -> "Bond":
        """The law with its parameters bound to the scene's numbers `values`."""
        return Bond(self, dict(values), self.placement_length(values, kT))


@dataclass(frozen=True)
class Bond:
    """A bond law with its parameters bound (numbers or traced arrays).

    Attributes:
        law: the BondLaw.
        parameters: its parameters (name → value).
        placement_length: the law's placement length for the scene's numbers.
    """

    law: BondLaw
    parameters: dict
    placement_length: float

    @property
    def name(self) -> str:
        return self.law.name

    @property
    def stiffness(self) -> Callable:
        """`stiffness(q_sq) -> T/Q`, elementwise, any float array."""
        return functools.partial(self.law.stiffness, **self.parameters)

    @property
    def energy(self) -> Callable:
        """`energy(q_sq) -> U`, elementwise."""
        return functools.partial(self.law.energy, **self.parameters)

    @property
    def max_extension(self):
        """Q0 (or R0) for finitely extensible laws, else None."""
        return self.law.max_extension(self.parameters)

    def with_parameters(self, values: dict) -> "Bond":
        """The same law with its parameters bound to `values` (e.g. traced arrays).

        Args:
            values: parameter name → value (scalar array), the keys of `parameters`.
        Returns:
            A Bond whose stiffness, energy and max_extension use `values`
            (placement_length stays the host-side value of the scene's parameters).
        """
        return dataclasses.replace(self, parameters=dict(values))


class Hookean(BondLaw):
    """Hookean spring T = H Q (thesis eq. 2.25); free ⟨Q²⟩ = 3 k_BT/H."""

    name = "hookean"
    parameters = {"spring_constant": Parameter()}

    def stiffness(self, q_sq, spring_constant):
        """H (the same at every length)."""
        return spring_constant * jnp.ones_like(q_sq)

    def energy(self, q_sq, spring_constant):
        """½ H Q²."""
        return 0.5 * spring_constant * q_sq

    def placement_length(self, values, kT):
        """The free root-mean-square length √(3 k_BT/H)."""
        return math.sqrt(3 * kT / values["spring_constant"])


class Fraenkel(BondLaw):
    """Fraenkel (harmonic, rest length r_eq) spring T = K (Q − r_eq).

    Its direction is undefined at Q = 0 when r_eq > 0; there the stiffness is taken
    at a tiny length instead (a configuration that thermal motion never reaches).

    Args:
        name: "fraenkel" or "harmonic" (the same law under two names).
    """

    parameters = {"spring_constant": Parameter(), "rest_length": Parameter(strictly_positive=False)}

    def __init__(self, name: str):
        self.name = name

    def stiffness(self, q_sq, spring_constant, rest_length):
        """K (1 − r_eq/Q), with Q floored at the smallest normal number."""
        length = jnp.sqrt(jnp.maximum(q_sq, jnp.finfo(q_sq.dtype).tiny))
        return spring_constant * (1 - rest_length / length)

    def energy(self, q_sq, spring_constant, rest_length):
        """½ K (Q − r_eq)²."""
        return 0.5 * spring_constant * (jnp.sqrt(q_sq) - rest_length) ** 2

    def placement_length(self, values, kT):
        """r_eq, or the Hookean free length √(3 k_BT/K) for r_eq = 0."""
        rest = values["rest_length"]
        return rest if rest > 0 else math.sqrt(3 * kT / values["spring_constant"])


class Fene(BondLaw):
    """Warner FENE spring T = H Q / (1 − Q²/Q0²) (thesis eqs. 2.26, 4.2)."""

    name = "fene"
    parameters = {"spring_constant": Parameter(), "max_extension": Parameter()}

    def stiffness(self, q_sq, spring_constant, max_extension):
        """H / max(1 − Q²/Q0², floor)."""
        denominator = 1 - q_sq / (max_extension * max_extension)
        return spring_constant / jnp.maximum(denominator, FENE_DENOMINATOR_FLOOR)

    def energy(self, q_sq, spring_constant, max_extension):
        """−½ H Q0² ln(1 − Q²/Q0²) (infinite at and past Q0)."""
        q0_sq = max_extension * max_extension
        return -0.5 * spring_constant * q0_sq * jnp.log1p(-q_sq / q0_sq)

    def max_extension(self, values):
        return values["max_extension"]

    def placement_length(self, values, kT):
        """The exact free root-mean-square length: ⟨Q²⟩ = 3 Q0²/(b + 5),
        b = H Q0²/k_BT (thesis eq. 4.8)."""
        h, q0 = values["spring_constant"], values["max_extension"]
        b = h * q0 * q0 / kT
        return q0 * math.sqrt(3 / (b + 5))


class FeneLogWca(Fene):
    """Kremer–Grest bond: the FENE log potential plus the WCA repulsion between the
    bonded beads (Ahlrichs & Dünweg eq. 8)."""

    name = "fene_log_wca"
    parameters = {
        "spring_constant": Parameter(),
        "max_extension": Parameter(),
        "wca_epsilon": Parameter(1.0, strictly_positive=False),
        "wca_sigma": Parameter(1.0),
    }

    def stiffness(self, q_sq, spring_constant, max_extension, wca_epsilon, wca_sigma):
        """FENE stiffness plus the WCA force F/Q, a push: a negative tension."""
        return super().stiffness(q_sq, spring_constant, max_extension) - wca_force_over_distance(
            q_sq, wca_epsilon, wca_sigma
        )

    def energy(self, q_sq, spring_constant, max_extension, wca_epsilon, wca_sigma):
        """FENE log energy plus the WCA energy 4ε[(σ/Q)¹² − (σ/Q)⁶ + ¼] inside 2^{1/6}σ."""
        return super().energy(q_sq, spring_constant, max_extension) + wca_energy(
            q_sq, wca_epsilon, wca_sigma
        )

    def check(self, values, path):
        """The WCA core must end inside the FENE range."""
        wca_range = WCA_RANGE_FACTOR * values["wca_sigma"]
        if not wca_range < values["max_extension"]:
            raise ValueError(
                f"{path}: the WCA range 2^(1/6) wca_sigma = {wca_range:.4g} "
                f"must be below max_extension = {values['max_extension']}"
            )

    def placement_length(self, values, kT):
        """Where the energy is lowest, to 1/1000 of R0."""
        k, r0 = values["spring_constant"], values["max_extension"]
        eps, sigma = values["wca_epsilon"], values["wca_sigma"]
        wca_range_sq = 2 ** (1 / 3) * sigma * sigma
        lengths = [r0 * x / 1000 for x in range(1, 1000)]
        energies = [
            -0.5 * k * r0 * r0 * math.log1p(-((q / r0) ** 2))
            + (
                4 * eps * ((sigma / q) ** 12 - (sigma / q) ** 6 + 0.25)
                if q * q < wca_range_sq
                else 0
            )
            for q in lengths
        ]
        return lengths[energies.index(min(energies))]


BOND_LAWS: Registry[BondLaw] = Registry("bond law", "polymers[].bond.law")
HOOKEAN = BOND_LAWS.register(Hookean())
BOND_LAWS.register(Fraenkel("fraenkel"))
BOND_LAWS.register(Fraenkel("harmonic"))
FENE = BOND_LAWS.register(Fene())
BOND_LAWS.register(FeneLogWca())


def read_bond(section, path: str) -> dict:
    """The resolved bond table of a `[[polymers]]` entry, read by its law.

    Args:
        section: the scene's `bond` table (or None when missing).
        path: its dotted path ("polymers[0].bond").
    """
    names = list(BOND_LAWS.names())
    if section is None:
        raise ValueError(f"{path}: required table is missing; law: {names}")
    check_keys(section, ("law", *{k for law in BOND_LAWS for k in law.parameters}), path)
    law = read_choice(section, "law", path, names)
    return BOND_LAWS.get(law).read(section, path)


def bond_law(table: dict, kT: float) -> Bond:
    """The bound law of a bond table {"law": name, parameter: value, ...}, checked and
    completed with its defaults by `read_bond`."""
    values = read_bond(table, "bond")
    return BOND_LAWS.get(values.pop("law")).bind(values, kT)


@dataclass(frozen=True)
class ChainBondResult:
    """Bonded forces of one block of chains.

    Attributes:
        forces: (C, M, 3) force on every bead.
        virial: (3, 3) Σ_springs r_ij ⊗ F_ij = −Σ Q ⊗ (T/Q) Q.
        overstretched: bool, some FENE spring at or past its maximum extension.
        past_half_box: bool, some spring cannot be told from its periodic images:
            in a box that reads springs by minimum image (Lees–Edwards,
            Kraynik–Reinelt) it is too long for its minimum image to be certain, or,
            with `half_box_limit`, it is longer than half a box edge along an axis.
    """

    forces: jnp.ndarray
    virial: jnp.ndarray
    overstretched: jnp.ndarray
    past_half_box: jnp.ndarray


def chain_bond_forces(box, positions, image, law: Bond, with_virial: bool, half_box_limit=False):
    """Spring forces of linear chains stored bead after bead.

    Args:
        box: the (bound) box; spring vectors by its `spring_vectors`: from unwrapped
            coordinates in a periodic box at rest (any length), by minimum image
            (thesis eq. 3.4) in a flowing one.
        positions: (C, M, 3) wrapped bead positions of C chains of M beads.
        image: (C, M, 3) int32 image counters of the beads.
        law: the bond law.
        with_virial: whether to compute the virial (else zeros).
        half_box_limit: also report springs with a component longer than half the
            box edge, for scenes where something else reads the springs by minimum
            image (the spring-pair list of jaxdpd.forces.spring_repulsion).
    Returns:
        ChainBondResult.
    """
    separation = positions[:, 1:] - positions[:, :-1]
    springs, past_half_box = box.spring_vectors(separation, image[:, 1:] - image[:, :-1])
    if half_box_limit:
        half = 0.5 * box.lengths_array(springs.dtype)
        past_half_box = past_half_box | jnp.any(jnp.abs(springs) > half)
    q_sq = jnp.sum(springs * springs, axis=-1)
    pull = law.stiffness(q_sq)[..., None] * springs
    zeros = jnp.zeros_like(pull[:, :1])
    forces = jnp.concatenate([pull, zeros], axis=1) - jnp.concatenate([zeros, pull], axis=1)
    if law.max_extension is None:
        overstretched = jnp.asarray(False)
    else:
        overstretched = jnp.any(q_sq >= law.max_extension**2)
    if with_virial:
        virial = -dyadic_sum(springs, pull)
    else:
        virial = jnp.zeros((3, 3), positions.dtype)
    return ChainBondResult(forces, virial, overstretched, past_half_box)
