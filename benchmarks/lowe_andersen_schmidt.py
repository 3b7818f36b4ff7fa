"""Viscosity, self-diffusion and Schmidt number of a Lowe–Andersen DPD fluid against Γ.

System: ρ = 3, a = 25, k_BT = 1, Δt = 0.01, r_T = r_c = 1, N particles in a periodic
box, for each bath collision frequency Γ (ΓΔt ≤ 1).

- Shear viscosity by Green–Kubo (jaxdpd.analysis.green_kubo), η = (V/k_BT)
  ∫₀^t_max ⟨P_αβ(0) P_αβ(t)⟩ dt over the off-diagonal components of the full
  pressure tensor (kinetic, conservative and Lowe–Andersen impulse parts, thesis
  eq. 3.47).  The
  impulse part is uncorrelated from step to step, so most of the integral is
  reached at the first lag; the rest decays within ~0.2 time units, hence t_max =
  0.5 (the value at t_max/2 is reported as a plateau check).  The integral is
  computed on `--blocks` consecutive blocks of the run; the mean and its standard
  error over the blocks are reported.
- Self-diffusion D from the particles' mean-square displacement, D = slope/6 for
  lags beyond 2 time units (jaxdpd.analysis.dynamics.diffusion_coefficient; the
  error counts particles as independent, which they are not quite).
- Schmidt number Sc = η/(ρ m D) (kinematic viscosity over self-diffusion).

Compared with Lowe's estimate of the thermostat's viscosity, η_L = π ρ² Γ r_c⁵/75
(Lowe, Europhys. Lett. 47, 145 (1999); thesis eq. 2.23), and with the expected
trends η ∝ Γ, D ∝ 1/Γ, Sc ∝ Γ² at small ΓΔt (thesis §2.3.2, fig. 2-2, from
Symeonidis et al.; screening at large ΓΔt bends Sc below Γ²).  Power laws are
fitted to η(Γ), D(Γ) and Sc(Γ) (jaxdpd.analysis.fits.fit_power_law).

Usage:
    python benchmarks/lowe_andersen_schmidt.py [--frequencies 10 25 50 100]
        [--count 1000] [--steps 20000] [--blocks 10] [--precision float64]
Writes benchmarks/results/lowe_andersen_schmidt.json.
"""

import argparse
import math

import jax
import numpy as np
from _common import print_table, write_json

from jaxdpd.analysis.dynamics import bead_msd, diffusion_coefficient
from jaxdpd.analysis.fits import fit_power_law
from jaxdpd.analysis.green_kubo import running_integral, shear_viscosity
from jaxdpd.analysis.statistics import block_average
from jaxdpd.engine.build import build
from jaxdpd.run import driver
from jaxdpd.scene import Scene

DENSITY, REPULSION, DT, KT = 3.0, 25.0, 0.01, 1.0
CHUNK = 100  # steps between stored positions (1 time unit)


def fluid(frequency: float, count: int, precision: str) -> Scene:
    return Scene.from_dict(
        {
            "seed": 7,
            "precision": precision,
            "particles": {"density": DENSITY, "count": count},
            "solvent": {"method": "lowe_andersen", "kT": KT, "collision_frequency": frequency},
            "pair": {"a": REPULSION},
            "integrator": {"dt": DT},
            "output": {"observables": ["temperature", "pressure"]},
        }
    )


def lowe_viscosity(frequency: float) -> float:
    """η_L = π ρ² Γ r_c⁵ / 75 (thesis eq. 2.23, unit mass and r_c)."""
    return math.pi * DENSITY**2 * frequency / 75


def measure(frequency: float, args) -> dict:
    scene = fluid(frequency, args.count, args.precision)
    simulation = build(scene)
    state = driver.run(simulation, simulation.init_fn(), args.equilibration, CHUNK)
    state = simulation.reallocate(state, None)
    stresses, temperatures, positions = [], [], []

    def collect(result):
        stresses.append(result.series["pressure_tensor"])
        temperatures.append(result.series["temperature"])
        unwrapped = simulation.box.unwrap(result.state.positions, result.state.image)
        positions.append(np.asarray(unwrapped, np.float64))

    driver.run(simulation, state, args.steps, CHUNK, on_chunk=collect)
    stress = np.concatenate(stresses).astype(np.float64)
    max_lag = round(args.max_time / DT)
    eta, eta_error = shear_viscosity(stress, scene.volume, KT, DT, max_lag, args.blocks)
    running = running_integral(stress, scene.volume, KT, DT, max_lag)
    trajectory = np.stack(positions)[:, :, None, :]  # (T, N, 1 bead, 3)
    msd = np.asarray(bead_msd(trajectory))
    lag_times = np.arange(len(msd)) * CHUNK * DT
    usable = lag_times <= lag_times[-1] / 4  # lags with many time origins
    diffusion, diffusion_error = diffusion_coefficient(lag_times[usable], msd[usable], fit_from=2.0)
    schmidt = eta / (DENSITY * diffusion)
    schmidt_error = schmidt * math.hypot(eta_error / eta, diffusion_error / diffusion)
    temperature, temperature_error = block_average(np.concatenate(temperatures), n_blocks=20)
    return {
        "collision_frequency": frequency,
        "probability": frequency * DT,
        "eta": eta,
        "eta_error": eta_error,
        "eta_at_half_t_max": float(running[max_lag // 2 - 1]),
        "eta_lowe": lowe_viscosity(frequency),
        "eta_over_lowe": eta / lowe_viscosity(frequency),
        "D": diffusion,
        "D_error": diffusion_error,
        "Sc": schmidt,
        "Sc_error": schmidt_error,
        "temperature": float(temperature),
        "temperature_error": float(temperature_error),
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--frequencies", type=float, nargs="+", default=[10, 25, 50, 100])
    parser.add_argument("--count", type=int, default=1000)
    parser.add_argument("--steps", type=int, default=20000)
    parser.add_argument("--equilibration", type=int, default=500)
    parser.add_argument("--blocks", type=int, default=10)
    parser.add_argument("--max-time", type=float, default=0.5, help="Green–Kubo t_max")
    parser.add_argument("--precision", default="float64")
    args = parser.parse_args()
    rows = []
    for frequency in args.frequencies:
        rows.append(measure(frequency, args))
        print_table(list(rows[-1]), rows[-1:])
    columns = [
        "collision_frequency",
        "probability",
        "eta",
        "eta_error",
        "eta_at_half_t_max",
        "eta_lowe",
        "eta_over_lowe",
        "D",
        "D_error",
        "Sc",
        "Sc_error",
        "temperature",
    ]
    print()
    print_table(columns, rows)
    frequencies = np.array([row["collision_frequency"] for row in rows])
    exponents = {}
    if len(rows) >= 3:
        for name in ("eta", "D", "Sc"):
            values = np.array([row[name] for row in rows])
            errors = np.array([row[f"{name}_error"] for row in rows])
            fit = fit_power_law(frequencies, values, errors)
            exponents[name] = fit["exponent"], fit.error("exponent")
            print(f"{name} ∝ Γ^{exponents[name][0]:.3f} ± {exponents[name][1]:.3f}")
    payload = {
        "count": args.count,
        "steps": args.steps,
        "dt": DT,
        "density": DENSITY,
        "repulsion": REPULSION,
        "green_kubo_max_time": args.max_time,
        "precision": args.precision,
        "rows": rows,
        "power_law_exponents": exponents,
    }
    print(f"wrote {write_json('lowe_andersen_schmidt', payload)}")


if __name__ == "__main__":
    jax.config.update("jax_enable_x64", True)
    main()
