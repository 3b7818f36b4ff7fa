"""Conservative pair forces.

Soft repulsion of Groot–Warren DPD (thesis eq. 2.4):
    F_ij^C = a_ij (1 − r_ij/r_c) e_ij   for r_ij < r_c, else 0,
with a symmetric species matrix a_ij (thesis §2.2.2, "Chemical species
differentiation").

Weeks–Chandler–Andersen repulsion between Kremer–Grest monomers (see `wca_term`).

Each law is one `PairLaw` component, registered in `PAIR_LAWS` under the name a
scene's `pair.kind` gives: it owns its fields of the `[pair]` section (their
reading, checks and resolved form), its cut-off if it fixes one, and the pair term
it adds to the step.
"""

import math
from dataclasses import dataclass

import jax.numpy as jnp

from jaxdpd.registry import Registry
from jaxdpd.validation import check_keys, read_choice, read_number


def soft_repulsion(weight, a):
    """Scalar law: magnitude a (1 − r/r_c) given the DPD weight w = 1 − r/r_c.

    Args:
        weight: w(r) = 1 − r/r_c within the cut-off, 0 beyond (any shape).
        a: repulsion parameter(s) a_ij, broadcastable to `weight` (energy/length).
    Returns:
        Force magnitude along e_ij (positive = repulsive).
    """
    return a * weight


def soft_repulsion_energy(distance, a, cutoff):
    """Pair potential U = a r_c (1 − r/r_c)² / 2 whose −dU/dr is `soft_repulsion`."""
    weight = jnp.clip(1 - distance / cutoff, 0, None)
    return 0.5 * a * cutoff * weight * weight


def soft_repulsion_term(a_matrix, dtype):
    """Pair term for the composed step: magnitude a_{s_i s_j} w(r_ij).

    Args:
        a_matrix: (S, S) symmetric nested sequence of a_ij.
        dtype: floating dtype of the simulation.
    Returns:
        `term(geometry, context) -> {"conservative": magnitudes}`, with
        `context.species` (N,) int32.
    """
    table = jnp.asarray(a_matrix, dtype)
    if table.shape == (1, 1):
        a = table[0, 0]
        return lambda geometry, context: {"conservative": soft_repulsion(geometry.weight, a)}

    def term(geometry, context):
        a = geometry.gather_pair(table, context.species)
        return {"conservative": soft_repulsion(geometry.weight, a)}

    return term


# Weeks–Chandler–Andersen repulsion (Weeks, Chandler and Andersen, J. Chem. Phys. 54,
# 5237 (1971)): the Lennard-Jones potential cut at its minimum r = 2^{1/6} σ and shifted
# to zero there, between all monomers of Kremer–Grest chains (Ahlrichs & Dünweg,
# J. Chem. Phys. 111, 8225 (1999), eq. 8):
#     U = 4ε [(σ/r)¹² − (σ/r)⁶ + ¼]   for r < 2^{1/6} σ, else 0,
#     F = −dU/dr = (24ε/r) [2 (σ/r)¹² − (σ/r)⁶]   (positive = repulsive).
WCA_RANGE_FACTOR = 2 ** (1 / 6)


def _wca_inverse_sixth(distance_sq, sigma):
    """(inside, (σ/r)⁶) with r² clamped to the range outside it (no overflow at r → ∞
    or division by zero in masked lanes)."""
    range_sq = WCA_RANGE_FACTOR**2 * sigma * sigma
    inside = distance_sq < range_sq
    safe = jnp.where(inside, distance_sq, range_sq)
    return inside, (sigma * sigma / safe) ** 3, safe


def wca_force_over_distance(distance_sq, epsilon, sigma):
    """Scalar law: F(r)/r = 24ε [2 (σ/r)¹² − (σ/r)⁶]/r² within 2^{1/6}σ, else 0.

    Args:
        distance_sq: r² (any shape, r > 0).
        epsilon: ε (energy); sigma: σ (length).
    Returns:
        F/r (force per length), ≥ 0.
    """
    inside, s6, safe = _wca_inverse_sixth(distance_sq, sigma)
    return jnp.where(inside, 24 * epsilon * (2 * s6 * s6 - s6) / safe, 0)


def wca_energy(distance_sq, epsilon, sigma):
    """U(r) = 4ε [(σ/r)¹² − (σ/r)⁶ + ¼] within 2^{1/6}σ, else 0."""
    inside, s6, _ = _wca_inverse_sixth(distance_sq, sigma)
    return jnp.where(inside, 4 * epsilon * (s6 * s6 - s6 + 0.25), 0)


def wca_term(epsilon: float, sigma: float, dtype):
    """Pair term for the composed step: the WCA force magnitude r · F/r.

    The scene's cut-off is the WCA range 2^{1/6}σ, so `geometry.within` is exactly
    the interaction range.

    Args:
        epsilon: ε; sigma: σ.
        dtype: floating dtype of the simulation.
    Returns:
        `term(geometry, context) -> {"conservative": magnitudes}`.
    """
    eps, sig = jnp.asarray(epsilon, dtype), jnp.asarray(sigma, dtype)

    def term(geometry, context):
        distance = geometry.distance
        magnitude = distance * wca_force_over_distance(distance * distance, eps, sig)
        return {"conservative": jnp.where(geometry.within, magnitude, 0)}

    return term


@dataclass(frozen=True)
class Pair:
    """The scene's conservative pair force: soft repulsion with species matrix a
    (S×S), or the WCA repulsion with epsilon and sigma (the same for all pairs)."""

    kind: str
    a: tuple[tuple[float, ...], ...] = ()
    epsilon: float = 1.0
    sigma: float = 1.0


class PairLaw:
    """A pair law: a component named by `pair.kind`.

    Subclasses set `name` and `fields` (the `[pair]` keys besides kind) and define
    `read`, `to_dict` and `term`; a law with a range of its own overrides `cutoff`.
    """

    name: str
    fields: tuple[str, ...]

    def read(self, section: dict, species) -> Pair:
        """The Pair of a `[pair]` section (keys already checked to be fields of some
        law, fields of other laws refused); `species` are the scene's Species."""
        raise NotImplementedError

    def to_dict(self, pair: Pair) -> dict:
        """The resolved `[pair]` section."""
        raise NotImplementedError

    def term(self, pair: Pair, dtype):
        """The pair term of the composed step, `term(geometry, context) -> dict`."""
        raise NotImplementedError

    def core_diameter(self, pair: Pair) -> float | None:
        """The distance closer than which no two particles may start (a hard core),
        or None for a soft law (jaxdpd.geometry.placement)."""
        return None

    def cutoff(self, pair: Pair, cutoff: float, given) -> float:
        """The interaction cut-off: the scene's `cutoff` unless the law fixes one.

        Args:
            pair: the scene's Pair.
            cutoff: the scene's cutoff (its default if not given).
            given: the `cutoff` field as the scene gives it, or None.
        """
        return cutoff


class SoftRepulsion(PairLaw):
    """Groot–Warren soft repulsion a_ij (1 − r/r_c) (thesis eq. 2.4); `a` is a number,
    a symmetric S×S list or a table of "A-B" species pairs."""

    name = "soft_repulsion"
    fields = ("a",)

    def read(self, section, species):
        names = [s.name for s in species]
        n = len(names)
        if "a" not in section:
            raise ValueError(
                "pair.a: required field is missing (number, S×S list or species table)"
            )
        a = section["a"]
        if isinstance(a, (int, float)) and not isinstance(a, bool):
            value = read_number(section, "a", "pair")
            matrix = [[value] * n for _ in range(n)]
        elif isinstance(a, dict):
            matrix = _species_table(a, names)
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
        return Pair(self.name, tuple(tuple(row) for row in matrix))

    def to_dict(self, pair):
        return {"kind": pair.kind, "a": [list(row) for row in pair.a]}

    def term(self, pair, dtype):
        return soft_repulsion_term(pair.a, dtype)


def _species_table(a: dict, names: list) -> list:
    """The S×S matrix of a table {"A-B": a_AB, ...} that names every species pair once."""
    n = len(names)
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
    return matrix


class Wca(PairLaw):
    """Weeks–Chandler–Andersen repulsion (ε, σ > 0, the same for all pairs), whose
    cut-off is its range 2^{1/6} σ."""

    name = "wca"
    fields = ("epsilon", "sigma")

    def read(self, section, species):
        positive = {"minimum": 0, "exclusive_minimum": True}
        return Pair(
            self.name,
            epsilon=read_number(section, "epsilon", "pair", **positive),
            sigma=read_number(section, "sigma", "pair", **positive),
        )

    def to_dict(self, pair):
        return {"kind": "wca", "epsilon": pair.epsilon, "sigma": pair.sigma}

    def term(self, pair, dtype):
        return wca_term(pair.epsilon, pair.sigma, dtype)

    def core_diameter(self, pair):
        """σ: closer starts would begin with enormous forces."""
        return pair.sigma

    def cutoff(self, pair, cutoff, given):
        """2^(1/6) σ; a given `cutoff` must equal it."""
        wca_range = WCA_RANGE_FACTOR * pair.sigma
        if given is not None and not math.isclose(given, wca_range, rel_tol=1e-9):
            raise ValueError(
                f"cutoff = {given!r}: with pair.kind = 'wca' the cut-off is the WCA "
                f"range 2^(1/6) sigma = {wca_range:.6g}; remove cutoff"
            )
        return wca_range


PAIR_LAWS: Registry[PairLaw] = Registry("pair law", "pair.kind")
PAIR_LAWS.register(SoftRepulsion())
PAIR_LAWS.register(Wca())


def read_pair(section: dict, species) -> Pair:
    """The Pair of a scene's `[pair]` section, read by the law its `kind` names
    (default "soft_repulsion").

    Args:
        section: the `[pair]` table.
        species: the scene's Species (for the soft repulsion's matrix).
    """
    check_keys(section, ("kind", *{key for law in PAIR_LAWS for key in law.fields}), "pair")
    kind = read_choice(section, "kind", "pair", PAIR_LAWS.names(), "soft_repulsion")
    law = PAIR_LAWS.get(kind)
    for other in PAIR_LAWS:
        misplaced = sorted(set(other.fields) & set(section) - set(law.fields))
        if misplaced:
            raise ValueError(
                f"pair.{misplaced[0]}: belongs to kind {other.name!r}; {kind!r} takes "
                f"{', '.join(law.fields)}"
            )
    return law.read(section, species)
