"""What accuracy costs in time: error of a reference observable against wall time, for
every solvent method and for Brownian dynamics (issue 12).

For each method the knobs that trade accuracy for speed are swept, and the error of a
reference observable is measured against an exact or converged value, beside the wall
time per unit of simulated time (whole jitted chunks, compilation excluded):

- Groot–Warren DPD (ρ = 3, a = 25, γ = 4.5, k_BT = 1): Δt × λ, float32/float64,
  neighbour skin.  ⟨k_BT⟩ against the set k_BT = 1 (exact); the pressure against the
  Δt = 0.01, λ = 0.65 float64 value of the same code (its own O(Δt²) bias is about a
  quarter of the Δt = 0.02 deviation).  Measured by `timestep_accuracy.measure`.
- Lowe–Andersen (same fluid, Γ = p/Δt): Δt at p = ΓΔt = 0.5, and p at Δt = 0.04.
  ⟨k_BT⟩ against 1.
- Hoogerbrugge–Koelman (Π0 = 1/3, ω = 4/3, Δ = 1/3, δt = 1, ρ = 3): the impulses do not
  scale with δt, so δt changes the model rather than its accuracy; swept are the
  precision and the neighbour skin, and ⟨k_BT⟩ (an output of the model, not an input)
  is compared with the float64, skin 0 value.
- MPCD (SRD, ρ = 10 per cell, α = 130°, 6³ cells, Lees–Edwards shear γ̇ = 0.2, cell-
  level Maxwell–Boltzmann thermostat): collision time h, float32/float64.  The shear
  viscosity −⟨P_yx⟩/γ̇ against the analytic SRD result (Mussawisade et al. 2005,
  eq. 6; `jaxdpd.solvents.mpcd.transport.SRDFluid`), itself an approximation (molecular
  chaos, number fluctuations neglected), so a resolved deviation may be the
  formula's as much as the simulation's.
- Lattice Boltzmann (the packaged Kremer–Grest chain of 30 beads, jaxdpd/scenes/
  lb_chain.toml, in a 12³ lattice, τ = 0.05): the bead MD step Δt, float32/float64.
  The beads' kinetic temperature against the set k_BT = 1.2 (equipartition).  A Δt
  at which the run stops with an error flag is listed with the driver's message.
- Brownian dynamics (FENE dumbbells, b = 50, semi-implicit predictor–corrector,
  units of the Clarke thesis eq. 4.10): Δt and the ensemble size.  At rest, ⟨Q²⟩
  against the exact 3b/(b + 5) (thesis eq. 4.8); in shear at De = 1, η_p =
  ⟨f Q_x Q_y⟩/De (thesis eq. 4.11) against its Δt = 0.01 value.

Every error carries its standard error (20 block averages of the sampled series,
`jaxdpd.analysis.statistics.block_average`; reference errors are added in quadrature).  A
setting is *acceptable* when the 2σ upper bound of its relative error is below 1 %;
the recommended setting of a method and observable is its cheapest acceptable one.
The cost is also given per element (particle, dumbbell, or lattice node + bead) and
simulated time unit; the time units differ between methods (DPD units, Lennard-Jones
units for lattice Boltzmann, λ_H for Brownian dynamics).  The cost per unit
error, `seconds_for_1%`, is the wall time the run would need for a 1 % standard error
(measured seconds × (σ_rel / 1 %)²).

Timings on a shared machine are noisy; compare ratios within one run.

Usage:
    python benchmarks/accuracy_cost.py            # ~15 min on a shared 2-core machine
    python benchmarks/accuracy_cost.py --quick    # smoke run, a few minutes
    python benchmarks/accuracy_cost.py --methods mpcd brownian   # a subset
Writes benchmarks/results/accuracy_cost.json and .png (--quick or --methods:
accuracy_cost_partial.json and .png in the temporary directory).
"""

import argparse
import json
import math
import tempfile
import time
import tomllib
from importlib import resources
from pathlib import Path

import jax
import numpy as np
from _common import machine, print_table, write_json
from timestep_accuracy import measure, sample

from jaxdpd import brownian
from jaxdpd.analysis.statistics import block_average
from jaxdpd.engine import errors
from jaxdpd.scene import Scene
from jaxdpd.solvents.mpcd.transport import SRDFluid

N_BLOCKS = 20
ACCEPTABLE = 0.01  # relative error bound of an acceptable setting
SHEAR_RATE = 0.2  # MPCD
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
    elements,
):
    """One table row: relative error ± its standard error and the costs.

    `elements` normalises the cost: particles (DPD, Lowe–Andersen, Hoogerbrugge–
    Koelman, MPCD), dumbbells (Brownian dynamics), lattice nodes + beads (lattice
    Boltzmann)."""
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
        "elements": elements,
        "wall_us_per_element_time_unit": 1e6 * wall / elements,
        "seconds_for_1%": seconds * (relative_error / ACCEPTABLE) ** 2,
    }


def _blocked(series, name, transform=None):
    """(mean, standard error) of 20 block averages of series[name] (transformed)."""
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
        time_units = m["steps"] * dt
        seconds = m["wall_s_per_time_unit"] * time_units
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
                time_units,
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
                    time_units,
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
    """Hoogerbrugge–Koelman fluid (default Π0, ω, Δ; δt = 1) in float32 with skins 0 and
    0.3 against float64, skin 0: ⟨k_BT⟩ over `steps` steps after 300."""
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
    """Sheared SRD fluid at each collision time h in float32, and h = 0.1 in float64:
    η = −⟨P_yx⟩/γ̇ over `collisions` collisions (after 500) against eq. 6."""
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
    """The packaged Kremer–Grest chain in a 12³ fluctuating lattice at bead time steps
    Δt (τ = 0.05 fixed), float32, and Δt = 0.01 in float64.  A Δt at which the run
    stops with an error flag is recorded as unstable, with the driver's message."""
    scene = tomllib.loads(resources.files("jaxdpd.scenes").joinpath("lb_chain.toml").read_text())
    edge = 12
    scene["box"] = {"lengths": [float(edge)] * 3}
    scene.pop("run")
    scene["output"] = {"observables": ["temperature"]}
    beads = scene["particles"]["count"]
    rows = []
    for dt, precision in [(dt, "float32") for dt in time_steps] + [(0.01, "float64")]:
        data = {**scene, "precision": precision, "integrator": {"dt": dt}}
        setting = f"dt={dt} tau=0.05 {precision}"
        try:
            series, seconds, time_units = _run(data, dt, sample_time, 10.0)
        except errors.SimulationError as error:
            rows.append(_unstable_row("lattice_boltzmann", setting, "bead kT", error))
            continue
        kT = scene["solvent"]["kT"]
        temperature = _blocked(series, "temperature")
        elements = edge**3 + beads
        rows.append(
            _row(
                "lattice_boltzmann",
                setting,
                "bead kT",
                *temperature,
                kT,
                0.0,
                seconds,
                time_units,
                elements,
            )
        )
    return rows


def _unstable_row(method, setting, observable, error):
    """A setting whose run stopped with an error flag (no error, no cost)."""
    return {"method": method, "setting": setting, "observable": observable, "stopped": str(error)}


# ---------------------------------------------------------------- Brownian dynamics
FENE_B = 50.0
DEBORAH = 1.0  # the shear rate of the η_p rows, in units of 1/λ_H


def _brownian_series(dt, n, sample_time, deborah):
    """Ensemble means (`ensemble_moments`: q2, fqq) of n FENE dumbbells in shear at
    `deborah` (0: at rest), started at exact equilibrium, relaxed for `sample_time`
    and then sampled over it (timed, compilation excluded).

    Returns:
        (samples, wall seconds, sampled time in λ_H).
    """
    spring = brownian.FENE(FENE_B)
    kappa = brownian.velocity_gradient("shear", deborah)
    sample_every = max(1, round(sample_time / dt) // BROWNIAN_SAMPLES)

    @jax.jit
    def advance(key, state):
        return brownian.simulate(
            key, state, kappa, spring, dt, n_samples=BROWNIAN_SAMPLES, sample_every=sample_every
        )

    key = jax.random.key(7)
    state = brownian.equilibrium_state(key, spring, n)
    state, _ = jax.block_until_ready(advance(jax.random.fold_in(key, 1), state))  # compile, relax
    start = time.perf_counter()
    _, samples = jax.block_until_ready(advance(jax.random.fold_in(key, 2), state))
    seconds = time.perf_counter() - start
    return samples, seconds, BROWNIAN_SAMPLES * sample_every * dt


def brownian_rows(settings, sample_time, shear_time_steps, shear_ensemble):
    """FENE dumbbells (b = 50).  At rest, for (Δt, ensemble size) `settings`: ⟨Q²⟩
    against the exact 3b/(b + 5) (thesis eq. 4.8).  In shear at De = 1, for each Δt
    of `shear_time_steps` (the first, smallest, is the reference): η_p = ⟨f Q_x Q_y⟩/De
    (thesis eq. 4.11) against the smallest-Δt value (the predictor–corrector is of
    weak order 2, so its own bias is (Δt_ref/Δt)² of the next one's)."""
    rows = []
    for dt, n in settings:
        samples, seconds, time_units = _brownian_series(dt, n, sample_time, 0.0)
        q2 = block_average(np.asarray(samples["q2"], np.float64), n_blocks=N_BLOCKS)
        exact = 3 * FENE_B / (FENE_B + 5)
        rows.append(
            _row(
                "brownian",
                f"dt={dt} N={n}",
                "<Q^2> at rest",
                *map(float, q2),
                exact,
                0.0,
                seconds,
                time_units,
                n,
            )
        )
    viscosities = {}
    for dt in shear_time_steps:
        samples, seconds, time_units = _brownian_series(dt, shear_ensemble, sample_time, DEBORAH)
        shear_stress = np.asarray(samples["fqq"][:, 0, 1], np.float64) / DEBORAH
        viscosities[dt] = (
            *map(float, block_average(shear_stress, n_blocks=N_BLOCKS)),
            seconds,
            time_units,
        )
    reference = viscosities[shear_time_steps[0]][:2]
    for dt in shear_time_steps[1:]:
        rows.append(
            _row(
                "brownian",
                f"dt={dt} N={shear_ensemble}",
                "eta_p at De=1",
                *viscosities[dt][:2],
                *reference,
                *viscosities[dt][2:],
                shear_ensemble,
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
    """Per method and observable: the cheapest acceptable setting (None if none is;
    rows are visited from the dearest, so the cheapest acceptable one is kept)."""
    choice = {f"{row['method']}: {row['observable']}": None for row in rows}
    for row in sorted(rows, key=lambda r: r["wall_s_per_time_unit"], reverse=True):
        if row["acceptable"]:
            choice[f"{row['method']}: {row['observable']}"] = row["setting"]
    return choice


def markdown_table(rows) -> str:
    """The README table: one line per measured or stopped setting."""
    lines = [
        "| method | setting | observable | value | reference | error | wall s / time unit "
        "| µs / element / time unit | s for 1 % σ |",
        "| --- | --- | --- | --- | --- | --- | --- | --- | --- |",
    ]
    for row in rows:
        start = f"| {row['method']} | {row['setting']} | {row['observable']} |"
        if "stopped" in row:
            lines.append(
                f"{start} stopped: {row['stopped'].split(':')[1].split(';')[0].strip()} | | | | | |"
            )
            continue
        mark = " **P**" if row["pareto"] else ""
        lines.append(
            f"{start} {row['value']:.4g} ± {row['value_err']:.2g} | {row['reference']:.4g} | "
            f"{row['rel_error_%']:+.2f} ± {row['rel_error_err_%']:.2f} %{mark} | "
            f"{row['wall_s_per_time_unit']:.3g} | {row['wall_us_per_element_time_unit']:.3g} | "
            f"{row['seconds_for_1%']:.3g} |"
        )
    return "\n".join(lines)


def plot(rows, path):
    """Log-log |relative error| against cost per element and time unit: a colour per
    method, a marker per observable, filled where the error is resolved (> 2σ), and
    each (method, observable)'s Pareto front as a line through its ringed points."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    floor = 1e-5  # where unresolved errors near zero are drawn on the log axis
    figure, axes = plt.subplots(figsize=(10, 5.5))
    markers = dict(zip(dict.fromkeys(r["observable"] for r in rows), "osD^vP*X", strict=False))
    colors = dict(zip(dict.fromkeys(r["method"] for r in rows), plt.cm.tab10.colors, strict=False))
    groups = {}
    for row in rows:
        groups.setdefault((row["method"], row["observable"]), []).append(row)
    for (method, observable), group in groups.items():
        color, marker = colors[method], markers[observable]
        for index, row in enumerate(group):
            x = row["wall_us_per_element_time_unit"]
            y = max(abs(row["rel_error_%"]) / 100, floor)
            sigma = row["rel_error_err_%"] / 100
            resolved = abs(row["rel_error_%"]) > 2 * row["rel_error_err_%"]
            axes.errorbar(
                x,
                y,
                yerr=[[min(sigma, y - floor)], [sigma]],
                color=color,
                marker=marker,
                markerfacecolor=color if resolved else "white",
                markeredgecolor=color,
                linestyle="none",
                capsize=2,
                label=f"{method}: {observable}" if index == 0 else None,
            )
            if row["pareto"]:
                axes.plot(
                    x, y, marker="o", markersize=13, markerfacecolor="none", markeredgecolor="black"
                )
        front = sorted(
            (r for r in group if r["pareto"]), key=lambda r: r["wall_us_per_element_time_unit"]
        )
        axes.plot(
            [r["wall_us_per_element_time_unit"] for r in front],
            [max(abs(r["rel_error_%"]) / 100, floor) for r in front],
            color=color,
            linewidth=1,
            alpha=0.6,
        )
    axes.axhline(ACCEPTABLE, color="grey", linestyle=":", linewidth=1)
    axes.set_xscale("log")
    axes.set_yscale("log")
    axes.set_xlabel("cost: wall µs per element (particle, dumbbell, lattice node) per time unit")
    axes.set_ylabel("|relative error|  (bars: 1 standard error)")
    axes.set_title("Accuracy against cost (ringed + line: Pareto front; open: not resolved at 2σ)")
    axes.legend(fontsize=8, loc="center left", bbox_to_anchor=(1.01, 0.5))
    figure.tight_layout()
    figure.savefig(path, dpi=110)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="a smoke run of a few minutes")
    parser.add_argument("--methods", nargs="+", help="a subset of the methods (default: all)")
    args = parser.parse_args()
    jax.config.update("jax_enable_x64", True)
    if args.quick:
        plan = {
            "dpd": lambda: dpd_rows(500, 2.0, [DPD_REFERENCE, (0.04, 0.65, "float32", 0.0)]),
            "lowe_andersen": lambda: lowe_andersen_rows(500, 2.0, [(0.04, 0.5)]),
            "hoogerbrugge_koelman": lambda: hoogerbrugge_koelman_rows(500, 100),
            "mpcd": lambda: mpcd_rows(200, (0.1, 1.0)),
            "lattice_boltzmann": lambda: lattice_boltzmann_rows(2.0, (0.01,)),
            "brownian": lambda: brownian_rows([(0.2, 1000)], 4.0, (0.02, 0.2), 1000),
        }
    else:
        plan = {
            "dpd": lambda: dpd_rows(
                2000,
                20.0,
                [
                    (dt, lam, "float64", 0.0)
                    for lam in (0.5, 0.65)
                    for dt in (0.01, 0.02, 0.04, 0.06)
                ]
                + [(0.04, 0.65, "float32", 0.0), (0.04, 0.65, "float32", 0.3)],
            ),
            "lowe_andersen": lambda: lowe_andersen_rows(
                2000, 10.0, [(dt, 0.5) for dt in (0.01, 0.02, 0.04, 0.06)] + [(0.04, 1.0)]
            ),
            "hoogerbrugge_koelman": lambda: hoogerbrugge_koelman_rows(2000, 1000),
            "mpcd": lambda: mpcd_rows(18000, (0.05, 0.1, 0.2, 0.5, 1.0)),
            "lattice_boltzmann": lambda: lattice_boltzmann_rows(40.0, (0.005, 0.01, 0.025, 0.05)),
            "brownian": lambda: brownian_rows(
                [(dt, 10000) for dt in (0.02, 0.1, 0.3)] + [(0.1, 1000), (0.1, 100000)],
                20.0,
                (0.01, 0.02, 0.1, 0.3),
                40000,
            ),
        }
    if args.methods:
        unknown = sorted(set(args.methods) - set(plan))
        if unknown:
            parser.error(f"--methods: unknown {unknown}; choose from {sorted(plan)}")
        plan = {method: plan[method] for method in args.methods}
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
    measured = [row for row in rows if "stopped" not in row]
    mark_pareto_and_acceptable(measured)
    choice = recommended(measured)
    print()
    print_table([*columns, "pareto", "acceptable"], measured)
    for row in rows:
        if "stopped" in row:
            print(f"{row['method']} {row['setting']}: stopped: {row['stopped']}")
    print("recommended:", choice)
    print(markdown_table(rows))
    payload = {"quick": args.quick, "methods": list(plan), "recommended": choice, "rows": rows}
    if args.quick or args.methods:  # a smoke or partial run leaves the results alone
        path = Path(tempfile.gettempdir()) / "accuracy_cost_partial.json"
        path.write_text(json.dumps({"machine": machine(), **payload}, indent=2))
    else:
        path = write_json("accuracy_cost", payload)
    plot(measured, path.with_suffix(".png"))
    print(f"wrote {path} and {path.with_suffix('.png')}")


if __name__ == "__main__":
    main()
