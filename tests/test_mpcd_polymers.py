"""Polymers in MPCD (Mussawisade et al., J. Chem. Phys. 123, 144905 (2005)).

- The solvent-free Rouse variant (§IV.A): each monomer's velocity is rotated alone,
  so a chain's centre-of-mass velocity keeps on average exactly 1 − γ_α of itself per
  collision (springs are internal forces) and eqs. 7 and 11 hold exactly with
  γ = γ_α (eq. 9), for any chain length and bond law.
- Gaussian chains (eq. 3, H = 3 k_BT/l²) in an SRD solvent sample the ideal-chain
  Boltzmann distribution: ⟨Q²⟩ = l², ⟨R_g²⟩ = l² (N² − 1)/(6N) (Doi & Edwards 1986,
  §2.1), whatever the hydrodynamics.
"""

import math

import jax
import jax.numpy as jnp
import numpy as np
import pytest
from mpcd_scenes import polymer_solution

from jaxdpd.analysis.dynamics import center_of_mass_msd, center_of_mass_vacf
from jaxdpd.analysis.statistics import block_average
from jaxdpd.engine.build import build
from jaxdpd.run import driver
from jaxdpd.scene import Scene
from jaxdpd.solvents.mpcd import transport

H = 0.1  # collision time


def rouse_scene(chains=100, beads=10, angle=60.0, mass=2.0):
    """Monomers only (no solvent), collision = "particle": the Rouse variant."""
    return Scene.from_dict(
        {
            "seed": 21,
            "precision": "float64",
            "box": {"lengths": [10, 10, 10]},
            "particles": {
                "count": chains * beads,
                "species": [{"name": "monomer", "count": chains * beads, "mass": mass}],
            },
            "solvent": {
                "method": "mpcd",
                "collision": "particle",
                "rotation_angle": angle,
                "collision_time": H,
            },
            "integrator": {"dt": 0.01},
            "polymers": [
                {
                    "species": "monomer",
                    "beads": beads,
                    "bond": {"law": "hookean", "spring_constant": 3.0},
                }
            ],
            "output": {"observables": []},
        }
    )


def _center_of_mass_series(scene, steps):
    """Bead velocities and unwrapped positions after every collision, (T, C, M, 3)."""
    simulation = build(scene)
    block = simulation.blocks[0]

    def sample(state):
        unwrapped = simulation.box.unwrap(state.positions, state.image)
        return block.take(state.velocities), block.take(unwrapped)

    @jax.jit
    def run(state):
        def body(state, _):
            state, _ = simulation.step_fn(state)
            return state, sample(state)

        return jax.lax.scan(body, state, None, length=steps)

    start = simulation.init_fn()
    last, (velocities, positions) = run(start)
    assert not int(last.flags)
    first_velocities, first_positions = sample(start)
    velocities = jnp.concatenate([first_velocities[None], velocities])
    positions = jnp.concatenate([first_positions[None], positions])
    return velocities, positions


def test_rouse_variant_center_of_mass_vacf_and_msd_are_eqs_7_and_11():
    """100 chains of 10 monomers (M = 2, H = 3), α = 60° (γ_α = 1/3), h = 0.1, h_p =
    0.01, 1500 collisions.  Per chain (chains are independent: nothing couples
    them), averaged over time origins:

        C(n) = ⟨v_cm(nh)·v_cm(0)⟩ = (1 − γ_α)^n C(0)                         (eq. 7)
        MSD(n) = 2 h² C(0) [(1/γ_α − ½) n − ((1 − γ_α) − (1 − γ_α)^{n+1})/γ_α²]  (eq. 11)
        C(0) = 3 k_BT/(M N_m)                                              (equipartition)

    The differences per chain have a mean within 4 standard errors (over chains) of
    zero at every tested lag."""
    scene = rouse_scene()
    velocities, positions = _center_of_mass_series(scene, 1500)
    vacf = np.asarray(center_of_mass_vacf(velocities))  # (T, chains)
    msd = np.asarray(center_of_mass_msd(positions))
    gamma = transport.rotation_factor(math.radians(60))
    assert gamma == pytest.approx(1 / 3)
    chains = vacf.shape[1]

    def check(differences, label):
        mean, error = differences.mean(), differences.std(ddof=1) / math.sqrt(chains)
        assert abs(mean) < 4 * error, (label, mean, error)

    check(vacf[0] - 3 / (2.0 * 10), "C(0)")
    for n in (1, 2, 3, 5, 8):
        check(vacf[n] - (1 - gamma) ** n * vacf[0], f"C({n})")
    for n in (1, 2, 5, 10, 30, 100):
        bracket = transport.center_of_mass_msd(n, gamma, H, 1.0, 1.0) / (6 * H**2)
        check(msd[n] - 2 * H**2 * vacf[0] * bracket, f"MSD({n})")
    # Eq. 12: D_cm = k_BT h/(M N_m)(1/γ − ½) is the long-time slope of eq. 11.
    slope = (
        transport.center_of_mass_msd(200, gamma, H, 1.0, 20.0)
        - transport.center_of_mass_msd(100, gamma, H, 1.0, 20.0)
    ) / (100 * H * 6)
    assert slope == pytest.approx(
        transport.center_of_mass_diffusion(gamma, H, 1.0, 20.0), rel=1e-12
    )


def gaussian_chain_scene(steps_per_chunk=500):
    """20 Gaussian chains of 5 monomers (M = ρm = 5, H = 3: l = 1) in 2460 solvent
    particles in an 8³ box (ρ = 5; tests/mpcd_scenes.py), α = 130°, h = 0.1, h_p =
    0.01.  A Gaussian spring longer than half the box edge (4 l) is flagged as
    ambiguous; its probability, P(χ²₃ > 48) ≈ 2·10⁻¹⁰ per spring and sample, keeps
    long runs clear of it (a 6³ box met it once in 2.4·10⁶ spring samples)."""
    return Scene.from_dict(
        polymer_solution(
            chains=20,
            beads=5,
            solvent_particles=2460,
            edge=8,
            seed=4,
            output={"observables": ["temperature", "conformation"]},
            run={"chunk": steps_per_chunk},
        )
    )


def _conformation_series(scene, steps):
    """Conformation series of `steps` collisions after one chunk of equilibration."""
    simulation = build(scene)
    state, _, _ = driver.run_chunk(simulation, simulation.init_fn(), scene.run.chunk)
    series = []
    for _ in range(steps // scene.run.chunk):
        state, samples, _ = driver.run_chunk(simulation, state, scene.run.chunk)
        series.append(samples)
    return {name: np.concatenate([s[name] for s in series]) for name in series[0]}


def _check_ideal_chain(series, n_particles, beads, n_blocks, sem_limit):
    """⟨Q²⟩ = 3 k_BT/H and ⟨R_g²⟩ = (3 k_BT/H)(N² − 1)/(6N) within 4 block-average
    standard errors (each below `sem_limit` relative, so that the check has teeth).

    Without a thermostat MPCD conserves energy, so k_BT is that of the initial draw,
    which differs from the nominal 1 by ~√(2/(3N_particles)) (1.6 % here): the
    reference uses the run's kinetic temperature Σ m v²/(3(N − 1)) (standard error
    ~10⁻⁴, negligible).  The velocity-Verlet bias of the configurational averages,
    O((ω h_p/2)²) ≈ 6·10⁻⁵ for ω² = 4H/M, is negligible too."""
    kinetic = np.trace(series["kinetic"], axis1=1, axis2=2)
    kT = float(np.mean(kinetic)) / (3 * (n_particles - 1))
    bond_length_sq = 3 * kT / 3.0
    for name, expected in (
        ("monomer/bond_length_sq", bond_length_sq),
        ("monomer/gyration_radius_sq", bond_length_sq * (beads**2 - 1) / (6 * beads)),
    ):
        mean, error = block_average(series[name], n_blocks=n_blocks)
        assert error < sem_limit * expected, (name, mean, error)
        assert abs(mean - expected) < 4 * error, (name, mean, expected, error)


def test_gaussian_chains_in_srd_solvent_have_ideal_statistics():
    """4000 collisions after 500 of equilibration (the Zimm time of these chains is
    ≈ 10 time units = 100 collisions); 20 blocks; standard errors ≤ 4 %."""
    scene = gaussian_chain_scene()
    series = _conformation_series(scene, 4000)
    _check_ideal_chain(series, scene.n_particles, 5, n_blocks=20, sem_limit=0.04)


@pytest.mark.slow
def test_gaussian_chains_in_srd_solvent_have_ideal_statistics_precisely():
    """As the default test, 90 000 collisions: standard errors ≤ 1 %."""
    scene = gaussian_chain_scene(2000)
    series = _conformation_series(scene, 90_000)
    _check_ideal_chain(series, scene.n_particles, 5, n_blocks=20, sem_limit=0.01)
