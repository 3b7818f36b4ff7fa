"""Material functions, conformation under flow and the Giesekus drag coefficient.

References:
- material functions of simple shear with P = −σ: η = −P_xy/γ̇, Ψ1 = (P_yy − P_xx)/γ̇²,
  Ψ2 = (P_zz − P_yy)/γ̇² (Bird, Armstrong & Hassager vol. 1, ch. 3; thesis eqs.
  4.12–4.13), checked on synthetic series with known means and independent Gaussian
  noise (standard error σ/√T exactly);
- Hookean dumbbells in steady shear have the exact second moments
  ⟨QQ⟩ = (k_BT/H) [δ + λ_H γ̇ (e_x e_y + e_y e_x) + 2 (λ_H γ̇)² e_x e_x], λ_H = ζ/(4H)
  (Bird, Curtiss, Armstrong & Hassager vol. 2, 2nd ed. (1987), §13.4), for which
  every form of the Giesekus–Kramers comparison (thesis eq. 4.18) returns ζ exactly;
- Brownian FENE dumbbells (no hydrodynamic interaction) obey the Giesekus stress
  expression exactly in steady state (Bird et al. vol. 2, §13.3), so eq. 4.18 applied
  to a jaxdpd.brownian run returns its drag coefficient ζ = 4 (units of H λ_H).

Tolerances: 4 standard errors (block averages, or independent-sample errors).
"""

import jax
import jax.numpy as jnp
import numpy as np
import pytest
from dumbbell_scenes import sheared_solution_with_tracers

from jaxdpd import brownian as bd
from jaxdpd.analysis import rheology
from jaxdpd.analysis.running_averages import RunningBlockAverages
from jaxdpd.analysis.statistics import inverse_variance_mean, ratio_of_means
from jaxdpd.forces.bonds import bond_law
from jaxdpd.geometry.boxes import PeriodicBox
from jaxdpd.geometry.chain_topology import ChainBlock
from jaxdpd.observables import chain_series, summary_rows
from jaxdpd.observables.drag import giesekus_drag

SIGMAS = 4.0
MEAN = np.array([[3.2, -0.3, 0.0], [-0.3, 3.0, 0.0], [0.0, 0.0, 3.1]])
NOISE = 0.5
SAMPLES = 4000


def noisy_tensor_series(seed, shape=()):
    rng = np.random.default_rng(seed)
    return MEAN + NOISE * rng.normal(size=shape + (SAMPLES, 3, 3))


def test_material_functions_of_a_known_stress():
    """η, Ψ1, Ψ2 within 4 standard errors of the exact values; the block-average
    error matches the exact σ/√T within 4 times its own relative uncertainty
    1/√(2 (n_blocks − 1)) (Flyvbjerg & Petersen 1989)."""
    rate = 0.5
    results = rheology.material_functions(noisy_tensor_series(1), rate)
    exact = {
        "viscosity": 0.3 / rate,
        "psi1": (3.0 - 3.2) / rate**2,
        "psi2": (3.1 - 3.0) / rate**2,
    }
    # P_xy is symmetrised (½(P_xy + P_yx), two independent noises); differences of
    # two diagonal entries carry √2 σ.
    exact_error = {
        "viscosity": NOISE / np.sqrt(2) / rate / np.sqrt(SAMPLES),
        "psi1": np.sqrt(2) * NOISE / rate**2 / np.sqrt(SAMPLES),
        "psi2": np.sqrt(2) * NOISE / rate**2 / np.sqrt(SAMPLES),
    }
    spread = SIGMAS / np.sqrt(2 * 19)
    for name, (mean, error) in results.items():
        assert abs(float(mean) - exact[name]) < SIGMAS * exact_error[name], name
        assert abs(float(error) / exact_error[name] - 1) < spread, name


def test_material_functions_of_an_ensemble_keep_the_replica_axis():
    """A (B, T, 3, 3) batch with one shear rate per replica gives the per-replica
    results; a replica at rest gets NaN."""
    series = noisy_tensor_series(2, (3,))
    rates = np.array([0.0, 0.5, 2.0])
    batch = rheology.material_functions(series, rates)
    for k in (1, 2):
        single = rheology.material_functions(series[k], rates[k])
        for name in rheology.MATERIAL_FUNCTIONS:
            np.testing.assert_allclose(batch[name][0][k], single[name][0], rtol=1e-12)
            np.testing.assert_allclose(batch[name][1][k], single[name][1], rtol=1e-12)
    assert all(np.isnan(batch[name][0][0]) for name in rheology.MATERIAL_FUNCTIONS)


def test_ratio_of_means_and_its_delta_method_error():
    """r = ⟨a⟩/⟨b⟩ of correlated independent pairs: within 4 standard errors of
    μa/μb, and the error equals the delta-method value √Var(a − r b)/(μb √T) within
    4 times its relative uncertainty 1/√(2 (n_blocks − 1))."""
    rng = np.random.default_rng(10)
    b = 2.0 + 0.3 * rng.normal(size=SAMPLES)
    a = 1.5 * b + 0.2 * rng.normal(size=SAMPLES) - 1.0  # μa = 2, correlated with b
    ratio, error = ratio_of_means(a, b)
    exact_error = np.sqrt(0.2**2 + (1.5 - 1.0) ** 2 * 0.3**2) / 2.0 / np.sqrt(SAMPLES)
    assert abs(float(ratio) - 1.0) < SIGMAS * exact_error
    assert abs(float(error) / exact_error - 1) < SIGMAS / np.sqrt(2 * 19)


def test_inverse_variance_mean_weights_each_estimate_by_its_precision():
    """By hand: estimates 1 ± 1 and 3 ± 2 have weights 1 and 1/4, so the mean is
    (1 + 3/4)/(5/4) = 1.4 ± 1/√(5/4); equal errors give the plain mean and σ/√n.
    Rows are combined separately along `axis`."""
    mean, error = inverse_variance_mean([1.0, 3.0], [1.0, 2.0])
    np.testing.assert_allclose([mean, error], [1.4, 1 / np.sqrt(1.25)], rtol=1e-12)
    means, errors = np.array([[1.0, 2.0, 6.0], [0.0, 1.0, 2.0]]), np.full((2, 3), 0.3)
    mean, error = inverse_variance_mean(means, errors, axis=1)
    np.testing.assert_allclose(mean, [3.0, 1.0], rtol=1e-12)
    np.testing.assert_allclose(error, 0.3 / np.sqrt(3), rtol=1e-12)
    with pytest.raises(ValueError, match="one shape"):
        inverse_variance_mean([1.0, 2.0], [1.0])


def test_stress_parts_add_up_and_the_bond_part_gives_the_polymer_functions():
    rng = np.random.default_rng(3)
    parts = {name: rng.normal(size=(200, 3, 3)) for name in ("kinetic", "conservative", "bond")}
    series = {f"pressure_tensor_part/{name}": value for name, value in parts.items()}
    series["pressure_tensor"] = sum(parts.values())
    results = rheology.shear_rheology(series, 0.3)
    total = results["viscosity"][0]
    summed = (
        results["viscosity_part/kinetic"][0]
        + results["viscosity_part/conservative"][0]
        + results["polymer/viscosity"][0]
    )
    np.testing.assert_allclose(total, summed, rtol=1e-12)
    alone = rheology.material_functions(parts["bond"], 0.3)
    for name in rheology.MATERIAL_FUNCTIONS:
        np.testing.assert_allclose(results[f"polymer/{name}"][0], alone[name][0], rtol=1e-12)
    with pytest.raises(ValueError, match="pressure_tensor"):
        rheology.shear_rheology({"temperature": np.ones(50)}, 0.3)


def _two_blocks():
    """A block of 3 FENE dumbbells and a block of 2 Hookean chains of 4 beads."""
    dumbbells = ChainBlock(
        "dumbbell",
        0,
        3,
        2,
        bond_law({"law": "fene", "spring_constant": 2.0, "max_extension": 3.0}, kT=1.0),
    )
    chains = ChainBlock(
        "chain", 6, 2, 4, bond_law({"law": "hookean", "spring_constant": 3.0}, kT=1.0)
    )
    rng = np.random.default_rng(4)
    springs = rng.uniform(-0.9, 0.9, size=(3 + 2 * 3, 3))
    box = PeriodicBox((10.0, 11.0, 12.0))
    starts = rng.uniform(0, 10, size=(5, 3))
    unwrapped = [np.stack([starts[c], starts[c] + springs[c]]) for c in range(3)]
    for c in range(2):
        steps = springs[3 + 3 * c : 6 + 3 * c]
        unwrapped.append(starts[3 + c] + np.concatenate([[np.zeros(3)], np.cumsum(steps, 0)]))
    positions = np.concatenate(unwrapped)
    lengths = np.asarray(box.lengths)
    return box, jnp.asarray(positions % lengths), (dumbbells, chains), springs, unwrapped


def test_conformation_samples_under_flow_quantities():
    """⟨QQ⟩, fractional extensions and ⟨R_e R_e⟩ equal their direct NumPy values on a
    hand-built configuration (across periodic boundaries); a traced Q0 changes the
    contour length; a Hookean chain has no fractional extension."""
    box, positions, blocks, springs, unwrapped = _two_blocks()
    samples = chain_series.conformation_samples(box, positions, blocks)
    q = springs[:3]
    np.testing.assert_allclose(
        samples["dumbbell/bond_conformation"], np.einsum("ka,kb->ab", q, q) / 3, rtol=1e-12
    )
    length = np.linalg.norm(q, axis=1)
    np.testing.assert_allclose(samples["dumbbell/fractional_extension"], np.mean(length / 3.0))
    np.testing.assert_allclose(
        samples["dumbbell/fractional_extension_sq"], np.mean(length**2) / 9.0, rtol=1e-12
    )
    ends = np.array([chain[-1] - chain[0] for chain in unwrapped[3:]])
    np.testing.assert_allclose(
        samples["chain/end_to_end_conformation"], np.einsum("ka,kb->ab", ends, ends) / 2
    )
    assert "chain/fractional_extension" not in samples
    chain_springs = springs[3:]
    np.testing.assert_allclose(
        samples["chain/bond_conformation"],
        np.einsum("ka,kb->ab", chain_springs, chain_springs) / 6,
        rtol=1e-12,
    )
    traced = {
        "bond": {
            "dumbbell": {"spring_constant": jnp.asarray(2.0), "max_extension": jnp.asarray(4.0)},
            "chain": {"spring_constant": jnp.asarray(3.0)},
        }
    }
    jitted = jax.jit(
        lambda p, parameters: chain_series.conformation_samples(box, p, blocks, parameters)
    )
    np.testing.assert_allclose(
        jitted(positions, traced)["dumbbell/fractional_extension"], np.mean(length / 4.0)
    )


def test_spring_pair_pressure_is_the_repulsion_across_each_spring():
    """(1/V) Σ Q ⊗ a (1 − |Q|/r_c) Q/|Q| over springs shorter than r_c (thesis eq.
    3.46 for the bonded pairs), by direct NumPy summation."""
    box, positions, blocks, springs, _ = _two_blocks()
    for block, q in ((blocks[0], springs[:3]), (blocks[1], springs[3:])):
        result = chain_series.spring_pair_pressure(box, positions, block, 25.0, 1.0, box.volume)
        expected = np.zeros((3, 3))
        for spring in q:
            length = np.linalg.norm(spring)
            if length < 1.0:
                expected += np.outer(spring, spring) * 25.0 * (1 - length) / length
        assert np.any(expected != 0)
        np.testing.assert_allclose(result, expected / box.volume, rtol=1e-12)


@pytest.mark.parametrize("component", ["shear", "normal", "xx"])
def test_giesekus_drag_of_exact_hookean_dumbbells(component):
    """Exact steady-shear ⟨QQ⟩ of Hookean dumbbells (module docstring) with the
    Kramers stress P_bond = −n H ⟨QQ⟩: eq. 4.18 returns ζ = 4 H λ_H."""
    spring_constant, zeta, kT, density, rate = 2.0, 3.4, 1.0, 0.4, 0.7
    weissenberg = zeta / (4 * spring_constant) * rate
    x, y = np.eye(3)[0], np.eye(3)[1]
    moments = (
        np.eye(3)
        + weissenberg * (np.outer(x, y) + np.outer(y, x))
        + 2 * weissenberg**2 * np.outer(x, x)
    )
    conformation = kT / spring_constant * moments
    series = np.broadcast_to(conformation, (40, 3, 3))
    pressure = -density * spring_constant * series
    estimate, error = giesekus_drag(pressure, series, rate, density, kT, component)
    np.testing.assert_allclose(estimate, zeta, rtol=1e-12)
    assert float(error) < 1e-12


def test_giesekus_drag_of_brownian_fene_dumbbells():
    """Brownian FENE dumbbells (b = 50, De = 1, no hydrodynamic interaction): eq. 4.18
    gives ζ = 4 in units of H λ_H (ensemble of 2048, errors over 32 independent groups
    of dumbbells, 4 standard errors)."""
    spring = bd.FENE(50.0)
    kappa = bd.velocity_gradient("shear", 1.0, jnp.float64)
    n_dumbbells, groups = 2048, 32
    state = bd.equilibrium_state(jax.random.key(5), spring, n_dumbbells, jnp.float64)

    def observe(q, spring):
        f = spring.force_factor(jnp.sum(q * q, axis=-1))
        grouped = q.reshape(groups, -1, 3)
        fq = (f[:, None] * q).reshape(groups, -1, 3)
        return {
            "fqq": jnp.einsum("gna,gnb->gab", fq, grouped) / grouped.shape[1],
            "qq": jnp.einsum("gna,gnb->gab", grouped, grouped) / grouped.shape[1],
        }

    state, _ = bd.simulate(jax.random.key(6), state, kappa, spring, 0.02, n_samples=1,
                           sample_every=300, observe=lambda q, s: None)  # fmt: skip
    _, samples = bd.simulate(jax.random.key(6), state, kappa, spring, 0.02, n_samples=50,
                             sample_every=20, observe=observe)  # fmt: skip
    # Groups are independent: their time averages are the samples of the error.
    pressure = -jnp.mean(samples["fqq"], axis=0)  # (G, 3, 3), n = 1, k_BT = 1
    conformation = jnp.mean(samples["qq"], axis=0)
    for component in ("shear", "normal"):
        estimate, error = giesekus_drag(pressure, conformation, 1.0, 1.0, 1.0, component)
        assert abs(float(estimate) - 4.0) < SIGMAS * float(error), (component, estimate, error)


def test_summary_rows_of_a_sheared_dumbbell_solution():
    """The run summary gets the material functions, the sheared ⟨QQ⟩ components, the
    Giesekus and tagged drag coefficients, each with the module functions' values;
    the block means that a streamed run keeps give the same rows."""
    scene = sheared_solution_with_tracers()  # γ̇ = 0.3, 40 springs, 4 of 300 tagged, F = 1
    rng = np.random.default_rng(7)
    series = {
        "pressure_tensor": noisy_tensor_series(8)[:100],
        "pressure_tensor_part/kinetic": noisy_tensor_series(9)[:100],
        "pressure_tensor_part/bond": -0.2 + 0.01 * rng.normal(size=(100, 3, 3)),
        "dumbbell/bond_conformation": 0.5 + 0.01 * rng.normal(size=(100, 3, 3)),
        "dumbbell/spring_pair_pressure": 0.05 + 0.01 * rng.normal(size=(100, 3, 3)),
        "drag/relative_velocity": 0.4 + 0.05 * rng.normal(size=(100, 3)),
    }
    rows = summary_rows(scene, series)
    assert rows["viscosity"][0] == pytest.approx(
        float(rheology.material_functions(series["pressure_tensor"], 0.3)["viscosity"][0])
    )
    for name in ("psi1", "psi2", "polymer/viscosity", "polymer/psi1", "viscosity_part/kinetic"):
        assert name in rows and np.isfinite(rows[name][1])
    for key in ("xy", "xx-yy", "yy-zz"):
        assert f"dumbbell/bond_conformation_{key}" in rows
    density = 40 / scene.volume
    expected = giesekus_drag(
        series["pressure_tensor_part/bond"], series["dumbbell/bond_conformation"], 0.3, density
    )
    assert rows["dumbbell/drag_giesekus"][0] == pytest.approx(float(expected[0]))
    total = series["pressure_tensor_part/bond"] + series["dumbbell/spring_pair_pressure"]
    with_repulsion = giesekus_drag(total, series["dumbbell/bond_conformation"], 0.3, density)
    assert rows["dumbbell/drag_giesekus_ev"][0] == pytest.approx(float(with_repulsion[0]))
    drift = series["drag/relative_velocity"][:, 0]
    zeta = 1.0 * 299 / (296 * np.mean(drift[drift.size % 20 :]))
    assert rows["drag/zeta"][0] == pytest.approx(zeta)
    # A streamed run keeps only block means (jaxdpd.analysis.running_averages): the same rows.
    averages = RunningBlockAverages(100)
    averages.add(0, {name: values[:60] for name, values in series.items()})
    averages.add(60, {name: values[60:] for name, values in series.items()})
    streamed = summary_rows(scene, averages.block_means(), averages.n_blocks)
    assert streamed.keys() == rows.keys()
    for name, (mean, error) in rows.items():
        assert streamed[name] == pytest.approx((mean, error), rel=1e-9), name
    # Too short a series gives no rows; a box at rest no material functions.
    assert summary_rows(scene, {k: v[:10] for k, v in series.items()}) == {}
    at_rest = scene.replace(flow=None, box={"kind": "periodic"})
    assert "viscosity" not in summary_rows(at_rest, series)
