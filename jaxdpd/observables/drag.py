"""Drag coefficient ζ of a DPD bead, by the two methods of Clarke's thesis §4.2.4.

ζ sets the dumbbell time scale λ_H = ζ/(4H) (thesis eq. 4.3), the unit of the
Deborah number De = γ̇ λ_H in which DPD and Brownian-dynamics flow curves are
compared.

(a) Tagged-particle forcing (jaxdpd.forces.body_forces.tagged_body_force, the "drag"
    observable): a force F x̂ on each of k tagged particles and −k F/(N − k) x̂ on
    each of the others.  The tagged particles drift through the rest with the mean
    relative velocity Δv = ⟨v̄_T − v̄_R⟩_x, and ζ = F/Δv (thesis: "ζ = F_applied /
    v_particle", k = 1).  Linear response (Kubo; the perturbation couples to
    x̄_T − x̄_R, the total momentum is zero) gives, for identical particles of
    self-diffusion coefficient D in the zero-momentum frame,

        Δv = F D N² / (k_BT (N − k)(N − 1)),

    using Σ_j ∫⟨v_i(t) v_j(0)⟩ dt = 0 (momentum conservation), so that the distinct
    velocity correlations of two tagged particles integrate to −D/(N − 1).  So
    `tagged_drag` reports the single-bead value ζ = (F/Δv)(N − 1)/(N − k), and the
    same quantity follows from diffusion alone (Einstein): ζ = k_BT (N − 1)²/(D N²)
    (`einstein_drag`).  Both carry the same finite-box hydrodynamics; for N → ∞,
    ζ → k_BT/D.

(b) Giesekus–Kramers comparison for dumbbells in steady shear (thesis eqs.
    4.15–4.18).  Kramers: τ_p = −n⟨Q F⟩ + n k_BT δ; Giesekus: τ_p = (n ζ/4) ⟨QQ⟩_(1)
    with, in steady shear, ⟨QQ⟩_(1),xy = −γ̇ ⟨Q_y Q_y⟩ and ⟨QQ⟩_(1),xx =
    −2γ̇ ⟨Q_x Q_y⟩ (eq. 4.17; τ = −σ, here the pressure P).  The spring part of the
    pressure tensor (thesis eq. 3.48, "pressure_tensor_part/bond") is
    P_bond = −n⟨Q F⟩ with n the number of springs per volume.  Components:

        "shear"   ζ = −4 P_bond,xy / (n γ̇ ⟨Q_y Q_y⟩)
        "normal"  ζ = −2 (P_bond,xx − P_bond,yy) / (n γ̇ ⟨Q_x Q_y⟩)
        "xx"      ζ = −2 (P_bond,xx + n k_BT) / (n γ̇ ⟨Q_x Q_y⟩)   (eq. 4.18 as printed)

    The "xx" form assumes the equilibrium ⟨Q F⟩ = k_BT δ of a free dumbbell; DPD
    dumbbells whose beads repel each other (Q < r_c) break it, which is the rise of
    ζ at low De in thesis fig. 4-3.  "shear" and "normal" use no equilibrium
    value.  In the derivation F is the whole intramolecular force; in DPD that is
    the spring plus the soft repulsion between the two beads (thesis §4.2.6), whose
    stress the "conformation" observable records as "<species>/spring_pair_pressure"
    (pass it as `intramolecular_pressure`; thesis eq. 4.18 itself uses the spring
    alone).  Giesekus's form also assumes a constant isotropic friction and no
    hydrodynamic interaction, which DPD has, so (b) agrees with (a) only within
    those caveats.

Error bars: block averages of the time series (jaxdpd.analysis.statistics), ratios by the
delta method (`ratio_of_means`).  Leading replica axes (ensembles) are kept.
"""

import jax.numpy as jnp
import numpy as np

from jaxdpd.analysis.statistics import block_average, ratio_of_means
from jaxdpd.observables.component import Observable, long_enough, summary_row
from jaxdpd.validation import SceneError

GIESEKUS_COMPONENTS = ("shear", "normal", "xx")


def relative_velocity_samples(velocities, tagged_range) -> dict:
    """Per-step sample of the "drag" observable (traced).

    Args:
        velocities: (N, 3) (peculiar) velocities.
        tagged_range: (first, count) of the tagged particles.
    Returns:
        {"drag/relative_velocity": (3,)} = mean velocity of the tagged particles
        minus that of the others (unweighted means; equal masses assumed by (a)).
    """
    first, count = tagged_range
    n = velocities.shape[0]
    tagged = velocities[first : first + count].sum(axis=0)
    rest = velocities.sum(axis=0) - tagged
    return {"drag/relative_velocity": tagged / count - rest / (n - count)}


def tagged_drag(relative_velocity_x, amplitude, n_tagged: int, n_particles: int, n_blocks=20):
    """Single-bead drag coefficient from the tagged-particle drift (method (a)).

    Args:
        relative_velocity_x: (..., T) series of Δv_x ("drag/relative_velocity"[..., 0]).
        amplitude: F on each tagged particle (scalar or (...)).
        n_tagged: k.
        n_particles: N.
        n_blocks: blocks of the time series for the error.
    Returns:
        (ζ, standard error), arrays of shape (...): ζ = (F/⟨Δv⟩)(N − 1)/(N − k).
    """
    drift, drift_error = block_average(jnp.asarray(relative_velocity_x), n_blocks=n_blocks, axis=-1)
    zeta = amplitude * (n_particles - 1) / ((n_particles - n_tagged) * drift)
    return zeta, jnp.abs(zeta) * drift_error / jnp.abs(drift)


def einstein_drag(diffusion, diffusion_error, n_particles: int, kT: float = 1.0):
    """The drag coefficient method (a) measures, from the self-diffusion coefficient
    D of the same particles: ζ = k_BT (N − 1)²/(D N²) (module docstring).

    Returns:
        (ζ, standard error).
    """
    zeta = kT * (n_particles - 1) ** 2 / (diffusion * n_particles**2)
    return zeta, zeta * diffusion_error / diffusion


def giesekus_drag(
    bond_pressure,
    bond_conformation,
    shear_rate,
    spring_density: float,
    kT: float = 1.0,
    component: str = "shear",
    n_blocks: int = 20,
    intramolecular_pressure=None,
):
    """Drag coefficient of dumbbell beads from the Giesekus–Kramers comparison
    (method (b), thesis eq. 4.18; module docstring).

    Args:
        bond_pressure: (..., T, 3, 3) "pressure_tensor_part/bond" series (springs of
            two-bead chains only).
        bond_conformation: (..., T, 3, 3) "<species>/bond_conformation" ⟨QQ⟩ series.
        shear_rate: γ̇ ≠ 0, scalar or (...) (one per replica).
        spring_density: n, springs per unit volume.
        kT: k_BT.
        component: "shear", "normal" or "xx" (module docstring).
        n_blocks: blocks of the time series for the error.
        intramolecular_pressure: (..., T, 3, 3) stress of the other intramolecular
            forces (e.g. "<species>/spring_pair_pressure"), added to bond_pressure;
            None: the spring alone (thesis eq. 4.18).
    Returns:
        (ζ, standard error), arrays of shape (...).
    """
    if component not in GIESEKUS_COMPONENTS:
        raise ValueError(f"component = {component!r}: valid are {list(GIESEKUS_COMPONENTS)}")
    pressure = jnp.asarray(bond_pressure)
    if intramolecular_pressure is not None:
        pressure = pressure + jnp.asarray(intramolecular_pressure)
    conformation = jnp.asarray(bond_conformation)
    if pressure.shape != conformation.shape or pressure.shape[-2:] != (3, 3):
        raise ValueError(
            f"bond_pressure {pressure.shape} and bond_conformation {conformation.shape} "
            "must both be (..., T, 3, 3)"
        )
    if np.any(np.asarray(shear_rate) == 0):
        raise ValueError("shear_rate: the Giesekus comparison needs γ̇ ≠ 0 (steady shear)")
    rate = jnp.asarray(shear_rate, pressure.dtype)[..., None]
    if component == "shear":
        numerator = -4 * pressure[..., 0, 1]
        denominator = conformation[..., 1, 1]
    elif component == "normal":
        numerator = -2 * (pressure[..., 0, 0] - pressure[..., 1, 1])
        denominator = conformation[..., 0, 1]
    else:
        numerator = -2 * (pressure[..., 0, 0] + spring_density * kT)
        denominator = conformation[..., 0, 1]
    return ratio_of_means(numerator, spring_density * rate * denominator, n_blocks, axis=-1)


class Drag(Observable):
    """The tagged particles' mean velocity relative to the others, per step; the drag
    coefficient "drag/zeta" in the run summary (`tagged_drag`)."""

    name = "drag"
    units = {"relative_velocity": "r_c/τ"}

    def example_scene(self, precision="float64") -> dict:
        """The example fluid with its chain beads pulled by a tagged body force."""
        data = super().example_scene(precision)
        data["body_force"] = {"kind": "tagged", "amplitude": 0.5, "species": "bead"}
        return data

    def check(self, scene):
        if scene.body_force is None or scene.body_force.kind != "tagged":
            raise SceneError(
                "output.observables",
                "'drag' measures the drift of tagged particles; add [body_force] kind = "
                "'tagged' with their species, or remove it",
            )

    def sampler(self, context):
        scene = context.scene
        tagged_range = scene.species_range(scene.body_force.species)

        def sample(previous, state):
            return state, relative_velocity_samples(state.velocities, tagged_range)

        return sample

    def summary_rows(self, scene, series, n_blocks):
        """The tagged-particle drag coefficient "drag/zeta" (`tagged_drag`)."""
        if not long_enough(series, "drag/relative_velocity", n_blocks):
            return {}
        force = scene.body_force
        _, tagged = scene.species_range(force.species)
        estimate = tagged_drag(
            series["drag/relative_velocity"][:, 0],
            force.amplitude,
            tagged,
            scene.n_particles,
            n_blocks,
        )
        return {"drag/zeta": summary_row(estimate)}
