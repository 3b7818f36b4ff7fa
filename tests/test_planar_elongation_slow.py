"""Long validations of planar elongation (marked slow; run with `pytest -m slow`).

- Elongational viscosities of the DPD solvent against its Lees–Edwards shear
  material functions, in boxes large enough for them to be those of the bulk fluid:
  the Trouton ratio η̄1 = 4η (thesis §4.3.3; eqs. 3.25–3.26 with eq. 5.12) and the
  second-order-fluid relation η̄2 = 2η − 4ε̇(Ψ1/2 + Ψ2) (derived in the test).
- The relaxation protocol of thesis §5.4.1 (eq. 5.15) on FENE chains.

Tolerances: 4 standard errors (20 block averages per replica; standard errors over
replicas for the relaxation curve), combined in quadrature.
"""

import jax.numpy as jnp
import numpy as np
import pytest
from conftest import scene_dict
from test_planar_elongation import elongation_scene, mean_and_error
from test_shear_flow import collect_series, sheared_scene

from jaxdpd.analysis.elongation import elongational_material_functions
from jaxdpd.analysis.statistics import inverse_variance_mean
from jaxdpd.engine.build import build
from jaxdpd.geometry import flows
from jaxdpd.run import driver, ensemble
from jaxdpd.scene import Scene
from jaxdpd.studies import relaxation

STEPS = 10000
SHEAR_RATE = 0.2


def shear_material_functions(replicas):
    """η and Ψ1/2 + Ψ2 of the DPD fluid at γ̇ = SHEAR_RATE (cube of N = 768), each
    with its standard error, from `replicas` independent Lees–Edwards runs.

    With the flow along x and the gradient along y, N1 = P_yy − P_xx = Ψ1 γ̇² and
    N2 = P_zz − P_yy = Ψ2 γ̇² (thesis convention π = P = p δ + τ, eq. 3.24), so
    Ψ1/2 + Ψ2 = (P_zz − (P_xx + P_yy)/2)/γ̇².
    """
    sheared = build(sheared_scene(0.0, 768, "float32", bins=4))
    seeds = list(range(100, 100 + replicas))
    batch = ensemble.replicate(
        sheared, sheared.init_fn(), seeds=seeds, shear_rates=[SHEAR_RATE] * replicas
    )
    batch = driver.run(sheared, batch, 250, 250)
    _, shear = collect_series(sheared, batch, STEPS, 500)
    tensor = shear["pressure_tensor"]
    viscosity = -tensor[..., 0, 1] / SHEAR_RATE
    normal = (tensor[..., 2, 2] - (tensor[..., 0, 0] + tensor[..., 1, 1]) / 2) / SHEAR_RATE**2
    return (
        inverse_variance_mean(*mean_and_error(viscosity, axis=1)),
        inverse_variance_mean(*mean_and_error(normal, axis=1)),
    )


@pytest.mark.slow
def test_elongational_viscosities_against_the_lees_edwards_material_functions():
    """η̄1/4 and η̄2/2 at ε̇ = 0.1 and 0.2 (four replicas each, box 8 × 4 × 8, N = 768,
    stable below ε̇ ≈ 0.7) against η, Ψ1 and Ψ2 at γ̇ = 0.2 (16 replicas, cube of
    N = 768).  These flows are slow (the viscosity is still rate-independent at rates
    of strain 2ε̇ ≤ 0.4; thesis fig. 4-5), so the stress is the retarded-motion
    expansion to second order, the second-order fluid (Bird, Armstrong & Hassager,
    Dynamics of Polymeric Liquids vol. 1, 2nd ed. 1987):
    τ = −η γ̇₍₁₎ + (Ψ1/2) γ̇₍₂₎ − Ψ2 γ̇₍₁₎·γ̇₍₁₎ with the zero-rate η, Ψ1 and Ψ2.

    In planar elongation (z stretches, x compresses; ∇u = diag(−ε̇, 0, ε̇), steady and
    homogeneous) γ̇₍₁₎ = diag(−2ε̇, 0, 2ε̇) and the upper-convected
    γ̇₍₂₎ = −(∇uᵀ·γ̇₍₁₎ + γ̇₍₁₎·∇u) = −γ̇₍₁₎·γ̇₍₁₎ = diag(−4ε̇², 0, −4ε̇²), so

        τ_xx = 2ηε̇ − 4ε̇²(Ψ1/2 + Ψ2),  τ_yy = 0,  τ_zz = −2ηε̇ − 4ε̇²(Ψ1/2 + Ψ2),

    and eqs. 3.25–3.26 give η̄1 = 4η exactly at this order but
    η̄2 = 2η − 4ε̇(Ψ1/2 + Ψ2): the Trouton ratio of η̄2 has a first-order correction.
    The DPD fluid's Ψ1/2 + Ψ2 is negative (its kinetic stress, over half of η,
    behaves like a gas's, whose P_xx exceeds P_yy in shear), so η̄2/2 lies 5 % above
    η at ε̇ = 0.2: 0.894 ± 0.005 against η = 0.851 ± 0.005 over 16 replicas each
    (benchmarks/elongation_second_order.py, which splits the stress by part: the
    kinetic part carries the difference).

    Errors: block averages, inverse-variance weighted over replicas.  In that
    benchmark the 16 replica means scatter 0.70–1.39 times their block errors,
    within the sampling scatter of a 15-degree-of-freedom spread."""
    rates = [0.1] * 4 + [0.2] * 4
    simulation = build(elongation_scene([8.0, 4.0, 8.0], 0.0))
    batch = ensemble.replicate(simulation, simulation.init_fn(), seeds=list(range(1, 9)))
    batch = driver.run(simulation, batch, 250, 250)
    batch = flows.set_flow_rate(batch, "planar_elongation", jnp.asarray(rates))
    _, series = collect_series(simulation, batch, STEPS, 500)
    functions = elongational_material_functions(series, np.asarray(rates), axis=1)

    (eta, eta_error), (psi, psi_error) = shear_material_functions(16)
    print(f"η = {eta:.4f} ± {eta_error:.4f}, Ψ1/2 + Ψ2 = {psi:.4f} ± {psi_error:.4f}")
    for rate in sorted(set(rates)):
        rows = np.asarray(rates) == rate
        eta1 = inverse_variance_mean(*(v[rows] / 4 for v in functions["eta1"]))
        eta2 = inverse_variance_mean(*(v[rows] / 2 for v in functions["eta2"]))
        expected2 = eta - 2 * rate * psi
        error2 = np.hypot(eta_error, 2 * rate * psi_error)
        print(
            f"ε̇ = {rate}: η̄1/4 = {eta1[0]:.4f} ± {eta1[1]:.4f} (η), "
            f"η̄2/2 = {eta2[0]:.4f} ± {eta2[1]:.4f} (η − 2ε̇(Ψ1/2 + Ψ2) = "
            f"{expected2:.4f} ± {error2:.4f})"
        )
        assert abs(eta1[0] - eta) < 4 * np.hypot(eta1[1], eta_error)
        assert abs(eta2[0] - expected2) < 4 * np.hypot(eta2[1], error2)


def chain_scene():
    """FENE chains (10 beads, H = 2, Q0 = 2.45 < 0.45 L_y, b = 12) with ideal beads
    (no conservative force on them) in the DPD solvent; box 8 × 5.5 × 8 (N = 1056, 30
    chains), stable below ε̇ ≈ 0.38.  Δt = 0.02: at Δt = 0.04 a thermal relative
    velocity of the ideal beads (4.6 along a spring at 0.94 Q0) carried a spring past
    Q0 in one step."""
    data = scene_dict(
        box={"lengths": [8.0, 5.5, 8.0]},
        integrator={"dt": 0.02, "lambda": 0.65},
        precision="float32",
        pair={"a": {"solvent-solvent": 25.0, "solvent-chain": 0.0, "chain-chain": 0.0}},
        polymers=[
            {
                "species": "chain",
                "beads": 10,
                "bond": {"law": "fene", "spring_constant": 2.0, "max_extension": 2.45},
            }
        ],
        flow={"kind": "planar_elongation", "elongation_rate": 0.0},
        output={"observables": ["temperature", "conformation"]},
    )
    data["particles"] = {
        "count": 1056,
        "species": [{"name": "solvent", "count": 756}, {"name": "chain", "count": 300}],
    }
    return Scene.from_dict(data)


@pytest.mark.slow
def test_chains_stretched_and_released_relax_to_equilibrium():
    """Thesis §5.4.1 protocol on eight replicas: stretched at ε̇ = 0.3 for a strain of
    3 the chains swell several-fold; with the rate set to zero the lattice stops
    (strain constant) and ⟨R_e²⟩ decays to its equilibrium value.

    Reference: the beads are ideal (no force but the springs), so the springs of a
    chain are independent and ⟨R_e²⟩ = (M − 1) ⟨Q²⟩ = (M − 1) 3 Q0²/(b + 5) (thesis
    eq. 4.8), 9.53 here.  Tolerances: 4 standard errors over the replicas (each
    replica's curve is independent of the others) plus 2 % for the time-step bias
    of the configurational temperature (at rest this scene gives ⟨Q²⟩ 1.1 % above
    eq. 4.8).  Checked: the mean of each replica's curve after t = 12 (8 fitted
    relaxation times), and the plateau L_e² of eq. 5.15 fitted to t ≥ 2 with its
    jackknife error over replicas."""
    simulation = build(chain_scene())
    scene = simulation.scene
    bond = scene.polymers[0].bond_parameters
    q0, beads = bond["max_extension"], scene.polymers[0].beads
    b = bond["spring_constant"] * q0**2 / scene.solvent.kT
    reference = (beads - 1) * 3 * q0**2 / (b + 5)
    batch = ensemble.replicate(simulation, simulation.init_fn(), seeds=list(range(1, 9)))
    batch = driver.run(simulation, batch, 1000, 250)
    strain_before = np.asarray(batch.box_state.strain)
    stretch_steps, rate = 500, 0.3
    result = relaxation.stretch_and_relax(
        simulation, batch, "chain", stretch_steps, 1250, 250, stretch_rate=rate, fit_after=2.0
    )
    late = result.per_replica[:, result.times >= 12].mean(axis=1)
    late_mean, late_error = late.mean(), late.std(ddof=1) / np.sqrt(len(late))
    fit = result.fit
    print(
        f"⟨R_e²⟩ reference {reference:.3f}, stretched {result.stretched:.2f}, after t = 12 "
        f"{late_mean:.3f} ± {late_error:.3f}; fit {fit.names} = {fit.values} ± {fit.errors}"
    )
    assert result.stretched > 3 * reference
    assert np.all(np.asarray(result.state.box_state.elongation_rate) == 0)
    period = simulation.box.period
    expected = strain_before + rate * scene.integrator.dt * stretch_steps
    expected = (expected + period / 2) % period - period / 2
    np.testing.assert_allclose(np.asarray(result.state.box_state.strain), expected, atol=1e-4)
    assert abs(late_mean - reference) < 4 * late_error + 0.02 * reference
    assert abs(fit["plateau"] - reference) < 4 * fit.error("plateau") + 0.02 * reference
    assert 0 < fit.error("relaxation_time") < 0.5 * fit["relaxation_time"]


def test_relaxation_protocol_names_what_the_scene_lacks():
    """The protocol refuses a species that is not chained and a scene that does not
    record the conformation, naming the field (building compiles nothing)."""
    scene = chain_scene()
    with pytest.raises(ValueError, match="species = 'solvent'"):
        relaxation.end_to_end_series_name(build(scene), "solvent")
    missing = scene.replace(output={"observables": ["temperature"]})
    with pytest.raises(ValueError, match="add 'conformation'"):
        relaxation.end_to_end_series_name(build(missing), "chain")
