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

A FENE spring cannot reach Q0: where a step takes it there the stiffness is
evaluated at a floor of the denominator (finite), and `overstretched` reports it so
that the driver stops with a message instead of producing NaNs.

Every law is a pure function of q² and its named parameters (`LAW_FORMS`), so the
parameters may also be traced arrays: `BondLaw.with_parameters` binds values taken
from `SimState.parameters` inside a step (one compiled step for every spring
constant; vmap over parameter sets; derivatives with respect to a parameter).
"""

import dataclasses
import functools
import math
from collections.abc import Callable
from dataclasses import dataclass

import jax.numpy as jnp

from jaxdpd.forces.pair_laws import wca_energy, wca_force_over_distance

# 1 − Q²/Q0² is floored here when a FENE spring is at or past Q0 (the step is
# flagged and the run stops at the end of the chunk).
FENE_DENOMINATOR_FLOOR = 1e-6

BOND_LAWS = ("hookean", "fraenkel", "harmonic", "fene", "fene_log_wca")


@dataclass(frozen=True)
class BondLaw:
    """A bond law with its parameters bound.

    Attributes:
        name: one of BOND_LAWS.
        parameters: the scene's parameters of the law (name → value).
        stiffness: `stiffness(q_sq) -> T/Q`, elementwise, any float array.
        energy: `energy(q_sq) -> U`, elementwise (for tests and diagnostics).
        max_extension: Q0 (or R0) for finitely extensible laws, else None.
        placement_length: a bond length to build chains with: where the law's
            energy is lowest if that is away from zero, else the root-mean-square
            length of a free spring at k_BT.
    """

    name: str
    parameters: dict
    stiffness: Callable
    energy: Callable
    max_extension: float | None
    placement_length: float

    def with_parameters(self, values: dict) -> "BondLaw":
        """The same law with its parameters bound to `values` (e.g. traced arrays).

        Args:
            values: parameter name → value (scalar array), the keys of `parameters`.
        Returns:
            A BondLaw whose stiffness, energy and max_extension use `values`
            (placement_length stays the host-side value of the scene's parameters).
        """
        stiffness, energy = LAW_FORMS[self.name]
        return dataclasses.replace(
            self,
            parameters=dict(values),
            stiffness=functools.partial(stiffness, **values),
            energy=functools.partial(energy, **values),
            max_extension=values.get("max_extension") if self.max_extension is not None else None,
        )


def _hookean_stiffness(q_sq, spring_constant):
    """H (the same at every length)."""
    return spring_constant * jnp.ones_like(q_sq)


def _hookean_energy(q_sq, spring_constant):
    """½ H Q²."""
    return 0.5 * spring_constant * q_sq


def hookean(spring_constant: float, kT: float) -> BondLaw:
    """Hookean spring T = H Q; free ⟨Q²⟩ = 3 k_BT/H."""
    h = spring_constant
    return BondLaw(
        "hookean",
        {"spring_constant": h},
        functools.partial(_hookean_stiffness, spring_constant=h),
        functools.partial(_hookean_energy, spring_constant=h),
        None,
        math.sqrt(3 * kT / h),
    )


def _fraenkel_stiffness(q_sq, spring_constant, rest_length):
    """K (1 − r_eq/Q), with Q floored at the smallest normal number."""
    length = jnp.sqrt(jnp.maximum(q_sq, jnp.finfo(q_sq.dtype).tiny))
    return spring_constant * (1 - rest_length / length)


def _fraenkel_energy(q_sq, spring_constant, rest_length):
    """½ K (Q − r_eq)²."""
    return 0.5 * spring_constant * (jnp.sqrt(q_sq) - rest_length) ** 2


def fraenkel(spring_constant: float, rest_length: float, kT: float) -> BondLaw:
    """Fraenkel (harmonic, rest length r_eq) spring T = K (Q − r_eq).

    Its direction is undefined at Q = 0 when r_eq > 0; there the stiffness is taken
    at a tiny length instead (a configuration that thermal motion never reaches).
    """
    k, rest = spring_constant, rest_length
    placement = rest if rest > 0 else math.sqrt(3 * kT / k)
    values = {"spring_constant": k, "rest_length": rest}
    return BondLaw(
        "fraenkel",
        values,
        functools.partial(_fraenkel_stiffness, **values),
        functools.partial(_fraenkel_energy, **values),
        None,
        placement,
    )


def _fene_stiffness(q_sq, spring_constant, max_extension):
    """k / max(1 − Q²/Q0², floor)."""
    denominator = 1 - q_sq / (max_extension * max_extension)
    return spring_constant / jnp.maximum(denominator, FENE_DENOMINATOR_FLOOR)


def _fene_energy(q_sq, spring_constant, max_extension):
    """−½ k Q0² ln(1 − Q²/Q0²) (infinite at and past Q0)."""
    q0_sq = max_extension * max_extension
    return -0.5 * spring_constant * q0_sq * jnp.log1p(-q_sq / q0_sq)


def fene(spring_constant: float, max_extension: float, kT: float) -> BondLaw:
    """Warner FENE spring; placed at its exact free ⟨Q²⟩ = 3 Q0²/(b + 5), b = H Q0²/k_BT
    (thesis eq. 4.8)."""
    h, q0 = spring_constant, max_extension
    b = h * q0 * q0 / kT
    values = {"spring_constant": h, "max_extension": q0}
    return BondLaw(
        "fene",
        values,
        functools.partial(_fene_stiffness, **values),
        functools.partial(_fene_energy, **values),
        q0,
        q0 * math.sqrt(3 / (b + 5)),
    )


def _fene_log_wca_stiffness(q_sq, spring_constant, max_extension, wca_epsilon, wca_sigma):
    """FENE stiffness plus the WCA force F/Q, a push: a negative tension."""
    return _fene_stiffness(q_sq, spring_constant, max_extension) - wca_force_over_distance(
        q_sq, wca_epsilon, wca_sigma
    )


def _fene_log_wca_energy(q_sq, spring_constant, max_extension, wca_epsilon, wca_sigma):
    """FENE log energy plus the WCA energy 4ε[(σ/Q)¹² − (σ/Q)⁶ + ¼] inside 2^{1/6}σ."""
    return _fene_energy(q_sq, spring_constant, max_extension) + wca_energy(
        q_sq, wca_epsilon, wca_sigma
    )


def fene_log_wca(
    spring_constant: float, max_extension: float, wca_epsilon: float, wca_sigma: float
) -> BondLaw:
    """Kremer–Grest bond: FENE log potential plus the WCA repulsion between the
    bonded beads (Ahlrichs & Dünweg eq. 8)."""
    k, r0, eps, sigma = spring_constant, max_extension, wca_epsilon, wca_sigma
    wca_range_sq = 2 ** (1 / 3) * sigma * sigma
    lengths = [r0 * x / 1000 for x in range(1, 1000)]
    energies = [
        -0.5 * k * r0 * r0 * math.log1p(-((q / r0) ** 2))
        + (4 * eps * ((sigma / q) ** 12 - (sigma / q) ** 6 + 0.25) if q * q < wca_range_sq else 0)
        for q in lengths
    ]
    values = {
        "spring_constant": k,
        "max_extension": r0,
        "wca_epsilon": eps,
        "wca_sigma": sigma,
    }
    return BondLaw(
        "fene_log_wca",
        values,
        functools.partial(_fene_log_wca_stiffness, **values),
        functools.partial(_fene_log_wca_energy, **values),
        r0,
        lengths[energies.index(min(energies))],
    )


# law name → (stiffness(q_sq, **parameters), energy(q_sq, **parameters)).
LAW_FORMS = {
    "hookean": (_hookean_stiffness, _hookean_energy),
    "fraenkel": (_fraenkel_stiffness, _fraenkel_energy),
    "harmonic": (_fraenkel_stiffness, _fraenkel_energy),
    "fene": (_fene_stiffness, _fene_energy),
    "fene_log_wca": (_fene_log_wca_stiffness, _fene_log_wca_energy),
}


def bond_law(parameters: dict, kT: float) -> BondLaw:
    """The law named by a scene's `polymers[k].bond` table (validated beforehand)."""
    name = parameters["law"]
    if name == "hookean":
        return hookean(parameters["spring_constant"], kT)
    if name in ("fraenkel", "harmonic"):
        law = fraenkel(parameters["spring_constant"], parameters["rest_length"], kT)
        return dataclasses.replace(law, name=name)
    if name == "fene":
        return fene(parameters["spring_constant"], parameters["max_extension"], kT)
    if name == "fene_log_wca":
        return fene_log_wca(
            parameters["spring_constant"],
            parameters["max_extension"],
            parameters["wca_epsilon"],
            parameters["wca_sigma"],
        )
    raise ValueError(f"bond.law = {name!r}: valid laws are {list(BOND_LAWS)}")


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


def chain_bond_forces(box, positions, image, law: BondLaw, with_virial: bool, half_box_limit=False):
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
        virial = -jnp.einsum("cka,ckb->ab", springs, pull)
    else:
        virial = jnp.zeros((3, 3), positions.dtype)
    return ChainBondResult(forces, virial, overstretched, past_half_box)
