"""What accuracy costs in time: error of a reference observable against wall time, for
every solvent method and for Brownian dynamics (issue 12).

For each method the knobs that trade accuracy for speed are swept, and the error of a
reference observable is measured against an exact or converged value, beside the wall
time per unit of simulated time (whole jitted chunks, compilation excluded):

- Groot–Warren DPD (ρ = 3, a = 25, γ = 4.5, k_BT = 1): Δt × λ, float32/float64,
  neighbour skin.  ⟨k_BT⟩ against the set k_BT = 1 (exact); the pressure against the
  Δt = 0.01, λ = 0.65 float64 value of the same code (converged to ~0.1 %, README
  time-step table).  Measured by `timestep_accuracy.measure`.
- Lowe–Andersen (same fluid, Γ = p/Δt): Δt at p = ΓΔt = 0.5, and p at Δt = 0.04.
  ⟨k_BT⟩ against 1.
- Hoogerbrugge–Koelman (Π0 = 1/3, ω = 4/3, Δ = 1/3, δt = 1, ρ = 3): the impulses do not
  scale with δt, so δt changes the model rather than its accuracy; swept are the
  precision and the neighbour skin, and ⟨k_BT⟩ (an output of the model, not an input)
  is compared with the float64, skin 0 value.
- MPCD (SRD, ρ = 10 per cell, α = 130°, 6³ cells, Lees–Edwards shear γ̇ = 0.1, cell-
  level Maxwell–Boltzmann thermostat): collision time h, float32/float64.  The shear
  viscosity −⟨P_yx⟩/γ̇ against the analytic SRD result (Mussawisade et al. 2005,
  eq. 6; `jaxdpd.mpcd.transport.SRDFluid`), which neglects correlations (a few %
  at small h, where it is least exact).
- Lattice Boltzmann (the packaged Kremer–Grest chain of 30 beads, jaxdpd/scenes/
  lb_chain.toml, in a 12³ lattice, τ = 0.05): the bead MD step Δt, float32/float64.
  The beads' kinetic temperature against the set k_BT = 1.2 (equipartition).
- Brownian dynamics (FENE dumbbells, b = 50, at rest, semi-implicit predictor–
  corrector): Δt and the ensemble size.  ⟨Q²⟩ against the exact 3b/(b + 5) (Clarke
  thesis eq. 4.8, units k_BT/H).

Every error carries its standard error (20 block averages of the sampled series,
`jaxdpd.statistics.block_average`; reference errors are added in quadrature).  A
setting is *acceptable* when the 2σ upper bound of its relative error is below 1 %;
the recommended setting of a method is its cheapest acceptable one.  The cost per unit
error, `seconds_for_1%`, is the wall time the run would need for a 1 % standard error
(measured seconds × (σ_rel / 1 %)²).

Timings on a shared machine are noisy; compare ratios within one run.

Usage:
    python benchmarks/accuracy_cost.py [--quick]
Writes benchmarks/results/accuracy_cost.json and accuracy_cost.png.
"""

import argparse
import copy
import math
import time
import tomllib
from importlib import resources

import jax
import jax.numpy as jnp
import numpy as np
from _common import RESULTS, print_table, write_json
from timestep_accuracy import measure, sample

from jaxdpd import brownian
from jaxdpd.mpcd.transport import SRDFluid
from jaxdpd.scene import Scene
from jaxdpd.statistics import block_average

N_BLOCKS = 20
ACCEPTABLE = 0.01  # relative error bound of an acceptable setting
SHEAR_RATE = 0.1  # MPCD
BROWNIAN_SAMPLES = 10 * N_BLOCKS  # ensemble means recorded per Brownian run


def _row(
    method,
    setting,
    observable,
    value,
    error,
    reference,
    reference_error,
    seconds,
    time_units,
    particles,
):
    """One table row: relative error ± its standard error and the costs."""
    relative = value / reference - 1
    relative_error = math.hypot(error / reference, value * reference_error / reference**2)
    wall = seconds / time_units
    return {
        "method": method,
        "setting": setting,
        "observable": observable,
        "value": value,
        "value_err": error,
        "reference": reference,
        "reference_err": reference_error,
        "rel_error_%": 100 * relative,
        "rel_error_err_%": 100 * relative_error,
        "wall_s_per_time_unit": wall,
        "particles": particles,
        "wall_us_per_particle_time_unit": 1e6 * wall / particles,
        "seconds_for_1%": seconds * (relative_error / ACCEPTABLE) ** 2,
    }


def _blocked(series, name, transform=None):
    values = series[name] if transform is None else transform(series[name])
    mean, error = block_average(np.asarray(values, np.float64), n_blocks=N_BLOCKS)
    return float(mean), float(error)


def _run(data, dt, sample_time, equilibration_time):
    """(series, seconds, simulated time) of a scene sampled over ~`sample_time`."""
    chunk = max(1, round(sample_time / dt) // N_BLOCKS)
    equilibration = chunk * math.ceil(equilibration_time / dt / chunk)
    series, seconds = sample(data, chunk * N_BLOCKS, chunk, equilibration)
    return series, seconds, chunk * N_BLOCKS * dt


# ------------------------------------------------------------------ particle solvents
DPD_REFERENCE = (0.01, 0.65, "float64", 0.0)


def dpd_rows(n, sample_time, settings):
    """Groot–Warren fluid at (Δt, λ, precision, skin) settings, which must include
    DPD_REFERENCE (the converged pressure)."""
    measured = {
        s: measure(n, *s[:2], sample_time, 5.0, precision=s[2], skin=s[3]) for s in settings
    }
    reference = measured[DPD_REFERENCE]
    rows = []
    for (dt, lam, precision, skin), m in measured.items():
        setting = f"dt={dt} lambda={lam} {precision} skin={skin}"
        seconds = m["wall_s_per_time_unit"]
        rows.append(
            _row(
                "dpd",
                setting,
                "kT",
                m["temperature"],
                m["temperature_err"],
                1.0,
                0.0,
                seconds,
                1.0,
                n,
            )
        )
        if m is not reference:
            rows.append(
                _row(
                    "dpd",
                    setting,
                    "pressure",
                    m["pressure"],
                    m["pressure_err"],
                    reference["pressure"],
                    reference["pressure_err"],
                    seconds,
                    1.0,
                    n,
                )
            )
    return rows


def particle_fluid(n, precision, solvent, integrator, skin=0.0):
    """ρ = 3 particle fluid (a = 25 unless Hoogerbrugge–Koelman) as a scene dict."""
    data = {
        "seed": 11,
        "precision": precision,
        "particles": {"density": 3.0, "count": n},
        "solvent": solvent,
        "integrator": integrator,
        "neighbors": {"skin": skin},
        "output": {"observables": ["temperature"]},
    }
    if solvent["method"] != "hoogerbrugge_koelman":
        data["pair"] = {"a": 25.0}
    return data


def lowe_andersen_rows(n, sample_time, settings):
    """Lowe–Andersen fluid at (Δt, ΓΔt) settings, float64."""
    rows = []
    for dt, probability in settings:
        solvent = {"method": "lowe_andersen", "kT": 1.0, "collision_frequency": probability / dt}
        data = particle_fluid(n, "float64", solvent, {"dt": dt})
        series, seconds, time_units = _run(data, dt, sample_time, 5.0)
        rows.append(
            _row(
                "lowe_andersen",
                f"dt={dt} Gamma*dt={probability} float64",
                "kT",
                *_blocked(series, "temperature"),
                1.0,
                0.0,
                seconds,
                time_units,
                n,
            )
        )
    return rows


def hoogerbrugge_koelman_rows(n, steps):
    measured = {}
    for precision, skin in (("float64", 0.0), ("float32", 0.0), ("float32", 0.3)):
        data = particle_fluid(n, precision, {"method": "hoogerbrugge_koelman"}, {"dt": 1.0}, skin)
        series, seconds, time_units = _run(data, 1.0, steps, 300.0)
        measured[(precision, skin)] = (*_blocked(series, "temperature"), seconds, time_units)
    reference, reference_error = measured[("float64", 0.0)][:2]
    return [
        _row(
            "hoogerbrugge_koelman",
            f"dt=1 {precision} skin={skin}",
            "kT",
            *m[:2],
            reference,
            reference_error,
            *m[2:],
            n,
        )
        for (precision, skin), m in measured.items()
        if (precision, skin) != ("float64", 0.0)
    ]


def mpcd_rows(collisions, collision_times):
    settings = [(h, "float32") for h in collision_times] + [(0.1, "float64")]
    rows = []
    for h, precision in settings:
        data = {
            "seed": 3,
            "precision": precision,
            "box": {"lengths": [6.0] * 3},
            "particles": {"density": 10.0},
            "flow": {"kind": "shear", "shear_rate": SHEAR_RATE},
            "solvent": {
                "method": "mpcd",
                "rotation_angle": 130.0,
                "collision_time": h,
                "thermostat": "maxwell_boltzmann_scaling",
            },
            "output": {"observables": ["temperature", "pressure"]},
        }
        scene = Scene.from_dict(data)
        expected = SRDFluid.from_scene(scene).shear_viscosity()
        series, seconds, time_units = _run(data, h, collisions * h, 500 * h)
        viscosity = _blocked(series, "pressure_tensor", lambda p: -p[:, 1, 0] / SHEAR_RATE)
        rows.append(
            _row(
                "mpcd",
                f"h={h} {precision}",
                "viscosity",
                *viscosity,
                expected,
                0.0,
                seconds,
                time_units,
                scene.n_particles,
            )
        )
    return rows


def lattice_boltzmann_rows(sample_time, time_steps):
    scene = tomllib.loads(resources.files("jaxdpd.scenes").joinpath("lb_chain.toml").read_text())
    scene["box"] = {"lengths": [12.0] * 3}
    scene.pop("run")
    scene["output"] = {"observables": ["temperature"]}
    rows = []
    for dt, precision in [(dt, "float32") for dt in time_steps] + [(0.01, "float64")]:
        data = copy.deepcopy(scene)
        data["precision"] = precision
        data["integrator"] = {"dt": dt}
        series, seconds, time_units = _run(data, dt, sample_time, 10.0)
        kT = data["solvent"]["kT"]
        rows.append(
            _row(
                "lattice_boltzmann",
                f"dt={dt} tau=0.05 {precision}",
                "bead kT",
                *_blocked(series, "temperature"),
                kT,
                0.0,
                seconds,
                time_units,
                30,
            )
        )
    return rows


# ---------------------------------------------------------------- Brownian dynamics
def _mean_square(connector, spring):
    del spring
    return jnp.mean(jnp.sum(connector * connector, axis=-1))


def brownian_rows(settings, sample_time):
    """FENE dumbbells at rest: ⟨Q²⟩ against 3b/(b + 5) for (Δt, ensemble size) settings."""
    spring = brownian.FENE(50.0)
    exact = 3 * 50.0 / 55.0
    kappa = jnp.zeros((3, 3))
    rows = []
    for dt, n in settings:
        sample_every = max(1, round(sample_time / dt) // BROWNIAN_SAMPLES)

        @jax.jit
        def advance(key, state, dt=dt, sample_every=sample_every):
            return brownian.simulate(
                key,
                state,
                kappa,
                spring,
                dt,
                n_samples=BROWNIAN_SAMPLES,
                sample_every=sample_every,
                observe=_mean_square,
            )

        key = jax.random.key(7)
        state = brownian.equilibrium_state(key, spring, n)
        state, _ = advance(jax.random.fold_in(key, 1), state)  # compile; relax the Δt bias
        jax.block_until_ready(state)
        start = time.perf_counter()
        _, series = jax.block_until_ready(advance(jax.random.fold_in(key, 2), state))
        seconds = time.perf_counter() - start
        mean, error = block_average(np.asarray(series, np.float64), n_blocks=N_BLOCKS)
        time_units = BROWNIAN_SAMPLES * sample_every * dt
        rows.append(
            _row(
                "brownian",
                f"dt={dt} N={n}",
                "<Q^2>",
                float(mean),
                float(error),
                exact,
                0.0,
                seconds,
                time_units,
                n,
            )
        )
    return rows


# ------------------------------------------------------------------------ analysis
def mark_pareto_and_acceptable(rows):
    """Per method and observable: `pareto` (no other setting is both cheaper and more
    accurate) and `acceptable` (|error| + 2σ < 1 %)."""
    for row in rows:
        row["acceptable"] = abs(row["rel_error_%"]) + 2 * row["rel_error_err_%"] < 100 * ACCEPTABLE
        peers = [
            r for r in rows if (r["method"], r["observable"]) == (row["method"], row["observable"])
        ]
        row["pareto"] = not any(
            r["wall_s_per_time_unit"] <= row["wall_s_per_time_unit"]
            and abs(r["rel_error_%"]) <= abs(row["rel_error_%"])
            and r is not row
            for r in peers
        )


def recommended(rows):
    """Per method: the cheapest setting all of whose observables are acceptable."""
    choice = {}
    for method in dict.fromkeys(r["method"] for r in rows):
        settings = {}
        for row in rows:
            if row["method"] == method:
                settings.setdefault(row["setting"], []).append(row)
        good = [group for group in settings.values() if all(r["acceptable"] for r in group)]
        if good:
            best = min(good, key=lambda group: group[0]["wall_s_per_time_unit"])
            choice[method] = best[0]["setting"]
        else:
            choice[method] = None
    return choice


def plot(rows, path):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    figure, axes = plt.subplots(figsize=(8, 5.5))
    markers = dict(zip(dict.fromkeys(r["observable"] for r in rows), "osD^vP*X", strict=False))
    colors = dict(zip(dict.fromkeys(r["method"] for r in rows), plt.cm.tab10.colors, strict=False))
    labelled = set()
    for row in rows:
        x = row["wall_us_per_particle_time_unit"]
        y = abs(row["rel_error_%"]) / 100
        sigma = row["rel_error_err_%"] / 100
        resolved = abs(row["rel_error_%"]) > 2 * row["rel_error_err_%"]
        label = f"{row['method']}: {row['observable']}"
        color = colors[row["method"]]
        axes.errorbar(
            x,
            max(y, 1e-5),
            yerr=[[min(sigma, max(y, 1e-5) - 1e-5)], [sigma]],
            color=color,
            marker=markers[row["observable"]],
            markersize=8 if row["pareto"] else 5,
            markerfacecolor=color if resolved else "white",
            markeredgecolor="black" if row["pareto"] else color,
            linestyle="none",
            label=None if label in labelled else label,
            capsize=2,
        )
        labelled.add(label)
    axes.axhline(ACCEPTABLE, color="grey", linestyle=":", linewidth=1)
    axes.set_xscale("log")
    axes.set_yscale("log")
    axes.set_xlabel("cost: wall µs per particle per simulated time unit (compile excluded)")
    axes.set_ylabel("|relative error| (bars: 1 standard error)")
    axes.set_title("Accuracy against cost (black edge: Pareto-optimal; open: not resolved at 2σ)")
    axes.legend(fontsize=7, loc="best")
    figure.tight_layout()
    figure.savefig(path, dpi=110)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="a ~2-minute smoke run")
    args = parser.parse_args()
    jax.config.update("jax_enable_x64", True)
    if args.quick:
        plan = {
            "dpd": lambda: dpd_rows(500, 2.0, [DPD_REFERENCE, (0.04, 0.65, "float32", 0.0)]),
            "lowe_andersen": lambda: lowe_andersen_rows(500, 2.0, [(0.04, 0.5)]),
            "hoogerbrugge_koelman": lambda: hoogerbrugge_koelman_rows(500, 100),
            "mpcd": lambda: mpcd_rows(200, (0.1, 1.0)),
            "lattice_boltzmann": lambda: lattice_boltzmann_rows(2.0, (0.01,)),
            "brownian": lambda: brownian_rows([(0.02, 1000), (0.2, 1000)], 4.0),
        }
    else:
        plan = {
            "dpd": lambda: dpd_rows(
                1500,
                10.0,
                [
                    (dt, lam, "float64", 0.0)
                    for lam in (0.5, 0.65)
                    for dt in (0.01, 0.02, 0.04, 0.06)
                ]
                + [(0.04, 0.65, "float32", 0.0), (0.04, 0.65, "float32", 0.3)],
            ),
            "lowe_andersen": lambda: lowe_andersen_rows(
                1500, 10.0, [(dt, 0.5) for dt in (0.01, 0.02, 0.04, 0.06)] + [(0.04, 1.0)]
            ),
            "hoogerbrugge_koelman": lambda: hoogerbrugge_koelman_rows(1500, 1000),
            "mpcd": lambda: mpcd_rows(6000, (0.05, 0.1, 0.2, 0.5, 1.0)),
            "lattice_boltzmann": lambda: lattice_boltzmann_rows(40.0, (0.005, 0.01, 0.025, 0.05)),
            "brownian": lambda: brownian_rows(
                [(dt, 10000) for dt in (0.005, 0.02, 0.1, 0.3)] + [(0.02, 1000), (0.02, 100000)],
                20.0,
            ),
        }
    rows = []
    columns = [
        "method",
        "setting",
        "observable",
        "value",
        "reference",
        "rel_error_%",
        "rel_error_err_%",
        "wall_s_per_time_unit",
        "seconds_for_1%",
    ]
    for method, run in plan.items():
        start = time.perf_counter()
        new = run()
        print(f"{method}: {time.perf_counter() - start:.0f} s")
        print_table(columns, new)
        rows += new
    mark_pareto_and_acceptable(rows)
    choice = recommended(rows)
    print()
    print_table([*columns, "pareto", "acceptable"], rows)
    print("recommended:", choice)
    name = "accuracy_cost_quick" if args.quick else "accuracy_cost"
    path = write_json(name, {"quick": args.quick, "recommended": choice, "rows": rows})
    plot(rows, RESULTS / f"{name}.png")
    print(f"wrote {path} and {name}.png")


if __name__ == "__main__":
    main()
