"""Single bead-spring chains in a Hoogerbrugge–Koelman fluid: the chain study of
Schlijper, Hoogerbrugge & Manke (J. Rheol. 39, 567 (1995)).

One chain of N beads per cubic box; the beads are fluid particles that also
exchange spring impulses in the collision-and-propagation update (δt = 1, m = r_c
= 1; Π0 = 1/3, ω = 4/3, Δ = 1/3; weight density n = 3 whatever the box holds).
Two spring models:
    weak    Hookean, H = 0.006, r_eq = 0
    strong  Fraenkel, K = 0.25, r_eq = 0.85
The box edge is L = max(2.2, 2.5 R_g,ideal(N)) with the ideal Hookean-chain
R_g² = b²(N² − 1)/(6N), b² = 3 k_BT/H (weak; for the strong spring b = r_eq); it
holds round(3 L³) particles.

Measured per (model, N), from the unwrapped chain positions stored every `--every`
updates over `--steps` updates after `--equilibration`:
    R_g²       mean over the stored frames (and, for N > 2, the per-step
               "conformation" series as a cross-check of the two code paths);
               standard error of 20 block averages.
    C(t)       normalised positional autocorrelation, C(t) = ⟨Σ_i u_i(t)·u_i(0)⟩ /
               ⟨Σ_i u_i²⟩, u_i the bead position from the centre of mass, so the
               unnormalised C(0) is N R_g² (jaxdpd.analysis.dynamics, exact FFT);
               the trajectory is cut into `--segments` pieces taken as independent
               samples (each ≫ τ1) for the jackknife.
    τ1         the slowest relaxation time: a weighted least-squares line through
               ln C(t) where 0.15 < C(t) < 0.6 (where the first Rouse/Zimm mode
               dominates; lags up to 3/4 of a segment), error by the jackknife over
               segments (which are only a few τ1 long for the longest chains of the
               quick mode, so those errors are rough).
    k_BT       the fluid's kinetic temperature (3N − 3 degrees of freedom).
    H⟨Q²⟩/3k_BT (weak) or ⟨(Q − r_eq) K Q⟩/3k_BT (strong; the virial form of
               equipartition, ⟨Q·∇U⟩ = 3 k_BT): 1 for Brownian dynamics of the same
               springs; the HK fluid is not exactly canonical (its collision rule
               violates fluctuation–dissipation, Español & Warren, Europhys. Lett. 30,
               191 (1995)), and the bonded beads also interact through the fluid
               (the Π0 repulsion, the fluid's potential of mean force), so this shows
               how far its chains are from the bare springs' statistics.
Fits: R_g² ∝ (N − 1)^{2ν} and τ1 ∝ N^α (jaxdpd.analysis.fits.fit_power_law,
weighted by the standard errors).  Rouse: ν = 1/2, α = 2 (1 + 2ν); Zimm with
ν = 1/2: α = 3/2.  For the dumbbell (N = 2) C(t) = ⟨Q(t)·Q(0)⟩/⟨Q²⟩, a single
exponential for a Hookean dumbbell in a Markovian bath: its τ from the early window
(0.5 < C < 0.9) is compared with τ1 from the late one.

Usage:
    python benchmarks/hk_chains.py [--full] [--beads 2 3 4 6 8 10] [--steps 100000]
        [--equilibration 2000] [--every 5] [--segments 10] [--models weak strong]
--full adds N = 15 and 20 and takes 4× the steps (τ1 grows as N²).
Writes benchmarks/results/hk_chains.json (hk_chains_full.json with --full).
"""

import argparse
import time
from functools import partial

import jax
import jax.numpy as jnp
import numpy as np
from _common import print_table, write_json

from jaxdpd.analysis.dynamics import positional_autocorrelation
from jaxdpd.analysis.fits import fit_power_law
from jaxdpd.analysis.statistics import block_average, ratio_of_means
from jaxdpd.engine import errors
from jaxdpd.engine.build import build
from jaxdpd.scene import Scene

DENSITY = 3.0
INITIAL_KT = 0.0016  # the default HK fluid's temperature (jaxdpd.scene)
MODELS = {
    "weak": {"law": "hookean", "spring_constant": 0.006},
    "strong": {"law": "fraenkel", "spring_constant": 0.25, "rest_length": 0.85},
}
FIT_WINDOW = (0.15, 0.6)  # C(t) range of the τ1 fit
EARLY_WINDOW = (0.5, 0.9)  # the dumbbell's early decay


def bond_length(bond: dict) -> float:
    """Root-mean-square ideal bond length: √(3 k_BT/H), or r_eq for the Fraenkel law."""
    if bond["law"] == "hookean":
        return float(np.sqrt(3 * INITIAL_KT / bond["spring_constant"]))
    return bond["rest_length"]


def box_edge(beads: int, bond: dict) -> float:
    """L = max(2.2, 2.5 R_g) with the ideal R_g² = b²(N² − 1)/(6N)."""
    gyration = bond_length(bond) * np.sqrt((beads**2 - 1) / (6 * beads))
    return round(max(2.2, 2.5 * gyration), 2)


def chain_scene(beads: int, bond: dict, seed: int) -> Scene:
    edge = box_edge(beads, bond)
    count = round(DENSITY * edge**3)
    return Scene.from_dict(
        {
            "seed": seed,
            "precision": "float64",
            "box": {"lengths": [edge] * 3},
            "particles": {
                "count": count,
                "species": [
                    {"name": "chain", "count": beads},
                    {"name": "solvent", "count": count - beads},
                ],
            },
            "solvent": {
                "method": "hoogerbrugge_koelman",
                "weight_density": DENSITY,
                "initial_kT": INITIAL_KT,
            },
            "polymers": [{"species": "chain", "beads": beads, "bond": bond}],
            "neighbors": {"method": "all_pairs"},
            "output": {"observables": ["temperature", "conformation"]},
        }
    )


@partial(jax.jit, static_argnums=(0, 2, 3, 4, 5))
def _frames(step_fn, state, frames: int, every: int, beads: int, lengths: tuple):
    """`frames` frames `every` updates apart: unwrapped chain positions (frames,
    beads, 3) in a box of edges `lengths`, Σ v² (twice the kinetic energy) and the
    mean of the per-step R_g² series (NaN for a dumbbell) over the frame."""
    edges = jnp.asarray(lengths, state.positions.dtype)

    def one_update(carry, _):
        state, samples = step_fn(carry)
        return state, samples.get("chain/gyration_radius_sq", jnp.nan)

    def frame(state, _):
        state, gyration = jax.lax.scan(one_update, state, None, length=every)
        positions = state.positions[:beads] + state.image[:beads] * edges
        return state, (positions, jnp.sum(state.velocities**2), jnp.mean(gyration))

    return jax.lax.scan(frame, state, None, length=frames)


def measure(beads: int, bond: dict, steps: int, equilibration: int, every: int, seed: int):
    """Run one chain; returns the trajectory (frames, beads, 3), kinetic series and
    the conformation R_g² series, and the wall time of the production run."""
    scene = chain_scene(beads, bond, seed)
    simulation = build(scene)
    state = simulation.init_fn()
    frames = partial(
        _frames, simulation.step_fn, every=every, beads=beads, lengths=scene.box.lengths
    )
    chunk = 200  # frames per jitted call
    start = time.perf_counter()
    state, _ = frames(state, equilibration // every)
    compiled = time.perf_counter()
    parts = []
    for done in range(0, steps // every, chunk):
        state, part = frames(state, min(chunk, steps // every - done))
        if int(state.flags):
            raise errors.SimulationError(errors.describe(int(state.flags)))
        parts.append(jax.tree.map(np.asarray, part))
    wall = time.perf_counter() - compiled
    trajectory, twice_kinetic, gyration = (np.concatenate(p) for p in zip(*parts, strict=True))
    temperature = twice_kinetic / (3 * scene.n_particles - 3)
    return scene, trajectory, temperature, gyration, wall, compiled - start


def fit_relaxation(correlation, error, times, window):
    """τ of C(t) ∝ exp(−t/τ) by weighted least squares on ln C where window[0] < C <
    window[1] (up to the first lag leaving it); None when fewer than 3 points."""
    inside = (correlation > window[0]) & (correlation < window[1])
    leaving = np.flatnonzero((correlation <= window[0]) & (times > 0))
    if leaving.size:
        inside &= np.arange(times.size) < leaving[0]
    if inside.sum() < 3:
        return None
    weight = (correlation[inside] / np.maximum(error[inside], 1e-12)) ** 2
    slope = np.polyfit(times[inside], np.log(correlation[inside]), 1, w=np.sqrt(weight))[0]
    return -1 / slope


def relaxation_time(trajectory, every, segments, window):
    """τ from the positional autocorrelation and its jackknife error over segments."""
    length = trajectory.shape[0] // segments
    pieces = trajectory[: segments * length].reshape(segments, length, *trajectory.shape[1:])
    lags = np.arange(3 * length // 4) * every  # long lags: fewer origins, kept to 3/4

    def tau_of(selected):
        stacked = np.moveaxis(pieces[selected], 0, 1)  # (T, segments, beads, 3)
        correlation, error = (
            np.asarray(a)[: lags.size] for a in positional_autocorrelation(stacked)
        )
        return fit_relaxation(correlation, error, lags, window), correlation, error

    tau, correlation, error = tau_of(np.arange(segments))
    left_out = [tau_of(np.delete(np.arange(segments), k))[0] for k in range(segments)]
    if tau is None or any(t is None for t in left_out):
        return None, None, correlation, error
    left_out = np.asarray(left_out)
    spread = np.sqrt((segments - 1) / segments * np.sum((left_out - left_out.mean()) ** 2))
    return tau, float(spread), correlation, error


def equipartition(trajectory, temperature, bond):
    """⟨Q·∇U⟩/(3 k_BT) with its block error: ⟨K (Q − r_eq) Q⟩ (H Q² for r_eq = 0)."""
    springs = np.linalg.norm(np.diff(trajectory, axis=1), axis=-1)
    rest = bond.get("rest_length", 0.0)
    virial = np.mean(bond["spring_constant"] * (springs - rest) * springs, axis=1)
    ratio, error = ratio_of_means(virial / 3, temperature)
    return float(ratio), float(error)


def study(model, bond, beads_list, steps, equilibration, every, segments):
    rows = []
    for beads in beads_list:
        scene, trajectory, temperature, gyration, wall, compile_time = measure(
            beads, bond, steps, equilibration, every, seed=beads
        )
        relative = trajectory - trajectory.mean(axis=1, keepdims=True)
        rg_sq, rg_error = block_average(np.mean(np.sum(relative**2, axis=-1), axis=1))
        kT, kT_error = block_average(temperature)
        tau, tau_error, correlation, _ = relaxation_time(trajectory, every, segments, FIT_WINDOW)
        ratio, ratio_error = equipartition(trajectory, temperature, bond)
        row = {
            "model": model,
            "N": beads,
            "L": scene.box.lengths[0],
            "particles": scene.n_particles,
            "Rg2": float(rg_sq),
            "Rg2_err": float(rg_error),
            "tau1": tau,
            "tau1_err": tau_error,
            "kT": float(kT),
            "kT_err": float(kT_error),
            "equipartition": ratio,
            "equipartition_err": ratio_error,
            "wall_s": round(wall, 1),
            "compile_s": round(compile_time, 1),
        }
        if beads > 2:
            series, series_error = block_average(gyration)
            row["Rg2_series"] = float(series)
            row["Rg2_series_err"] = float(series_error)
        else:
            early, early_error, _, _ = relaxation_time(trajectory, every, segments, EARLY_WINDOW)
            row["tau_early"], row["tau_early_err"] = early, early_error
        print_table(list(row), [row])
        rows.append(row)
    return rows


def ideal_bond_square(bond: dict, kT: float) -> float:
    """⟨Q²⟩ of a free spring at k_BT (Brownian dynamics samples exactly this):
    3 k_BT/H for the Hookean law, ∫ Q⁴ e^{−U/k_BT} dQ / ∫ Q² e^{−U/k_BT} dQ with
    U = ½ K (Q − r_eq)² for the Fraenkel law (numerical quadrature)."""
    if bond["law"] == "hookean":
        return 3 * kT / bond["spring_constant"]
    spread = np.sqrt(kT / bond["spring_constant"])
    lengths = np.linspace(0, bond["rest_length"] + 12 * spread, 200001)
    weight = lengths**2 * np.exp(-0.5 * ((lengths - bond["rest_length"]) / spread) ** 2)
    return float(np.sum(lengths**2 * weight) / np.sum(weight))


def add_references(rows, bond):
    """Brownian-dynamics references for each row, at the row's measured k_BT:
    Rg2_ideal = ⟨Q²⟩ (N² − 1)/(6N), the ideal (no bead–bead force) chain's R_g²
    (exact for Hookean springs, Doi & Edwards §2.1; for freely jointed springs of
    that ⟨Q²⟩ too, the bonds being independent); for Hookean springs
    tau1_rouse = τ_2 sin²(π/4)/sin²(π/(2N)), the Rouse chain's slowest time with the
    bead friction ζ that the measured dumbbell time τ_2 = ζ/(4H sin²(π/4)) implies
    (the discrete Rouse chain's modes, τ_p = ζ/(4H sin²(pπ/(2N))); Doi & Edwards,
    The Theory of Polymer Dynamics (1986), §4.1)."""
    dumbbell = next((r for r in rows if r["N"] == 2 and r["tau1"] is not None), None)
    for row in rows:
        beads = row["N"]
        row["Rg2_ideal"] = ideal_bond_square(bond, row["kT"]) * (beads**2 - 1) / (6 * beads)
        if bond["law"] == "hookean" and dumbbell is not None:
            scale = np.sin(np.pi / 4) ** 2 / np.sin(np.pi / (2 * beads)) ** 2
            row["tau1_rouse"] = dumbbell["tau1"] * scale
            row["tau1_rouse_err"] = dumbbell["tau1_err"] * scale


def exponents(rows):
    """ν from R_g² ∝ (N − 1)^{2ν}, α from τ1 ∝ N^α, with their standard errors; and
    the same fits to the Brownian-dynamics references of `add_references`
    (nu_ideal, alpha_rouse: what an ideal Rouse chain gives over the same N, which
    for so short chains is not 1/2 and 2: (N² − 1)/(6N) and 1/sin²(π/(2N)) are not
    yet power laws)."""
    beads = np.asarray([r["N"] for r in rows], float)
    gyration = fit_power_law(beads - 1, [r["Rg2"] for r in rows], [r["Rg2_err"] for r in rows])
    ideal = fit_power_law(beads - 1, [r["Rg2_ideal"] for r in rows])
    result = {
        "nu": 0.5 * gyration.values[1],
        "nu_err": 0.5 * gyration.errors[1],
        "nu_chi2_per_dof": gyration.chi_squared / max(gyration.degrees_of_freedom, 1),
        "nu_ideal": 0.5 * ideal.values[1],
    }
    timed_rows = [r for r in rows if r["tau1"] is not None]
    if len(timed_rows) >= 2:
        relaxation = fit_power_law(
            [r["N"] for r in timed_rows],
            [r["tau1"] for r in timed_rows],
            [r["tau1_err"] for r in timed_rows],
        )
        result |= {
            "alpha": relaxation.values[1],
            "alpha_err": relaxation.errors[1],
            "alpha_chi2_per_dof": relaxation.chi_squared / max(relaxation.degrees_of_freedom, 1),
        }
    rouse_rows = [r for r in rows if "tau1_rouse" in r]
    if len(rouse_rows) >= 3:
        rouse = fit_power_law([r["N"] for r in rouse_rows], [r["tau1_rouse"] for r in rouse_rows])
        result["alpha_rouse"] = rouse.values[1]
    return result


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--full", action="store_true")
    parser.add_argument("--beads", type=int, nargs="+", default=[2, 3, 4, 6, 8, 10])
    parser.add_argument("--models", nargs="+", default=list(MODELS), choices=list(MODELS))
    parser.add_argument("--steps", type=int, default=100000)
    parser.add_argument("--equilibration", type=int, default=2000)
    parser.add_argument("--every", type=int, default=5)
    parser.add_argument("--segments", type=int, default=10)
    args = parser.parse_args()
    beads_list, steps = args.beads, args.steps
    if args.full:
        beads_list, steps = sorted({*beads_list, 15, 20}), 4 * steps
    results = {"settings": vars(args) | {"beads": beads_list, "steps": steps}, "models": {}}
    for model in args.models:
        rows = study(
            model, MODELS[model], beads_list, steps, args.equilibration, args.every, args.segments
        )
        add_references(rows, MODELS[model])
        print_table(
            ["model", "N", "Rg2", "Rg2_err", "Rg2_ideal", "tau1", "tau1_err", "tau1_rouse"], rows
        )
        fit = exponents(rows)
        print(model, {k: round(float(v), 4) for k, v in fit.items()})
        fit = {k: float(v) for k, v in fit.items()}
        results["models"][model] = {"bond": MODELS[model], "rows": rows, "fit": fit}
    path = write_json("hk_chains_full" if args.full else "hk_chains", results)
    print(f"wrote {path}")


if __name__ == "__main__":
    main()
