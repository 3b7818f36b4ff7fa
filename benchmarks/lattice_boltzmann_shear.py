"""The lattice-Boltzmann fluid in Lees–Edwards shear: the layers of a fluctuating
sheared fluid (velocity, temperature) with the arriving layer translated spectrally
(jaxdpd) or by linear interpolation (ESPResSo's choice), and the cost of the sheared
LB step against the step at rest, measured in one process.

Profiles: 8 × 16 × 8 nodes, a = τ = ρ₀ = 1, ν = 0.1, ν_b = 0.3, k_BT = 1e-4 (thermal
Mach number² 3e-4), γ̇ = 0.0025 (γ̇ L_y = 0.04 a/τ), float64, uniform noise; started in
the laminar state plus equilibrium fluctuations, 200 steps skipped, then `--steps`
LB steps in 20 time blocks.  Per layer: the mean u_x and the temperature, the
variance of the momentum modes about the laminar state over its equilibrium value
μ b_1 (1 = equipartition), with block-average standard errors.

Cost: a thermal float32 fluid of `--size`³ nodes, the LB step at rest and sheared
(jitted `lax.scan` chunks of 50 steps after a warm-up chunk), best of 3.

Usage:
    python benchmarks/lattice_boltzmann_shear.py [--steps 4000] [--size 32]
Writes benchmarks/results/lattice_boltzmann_shear.json and .png.
"""

import argparse

import jax
import jax.numpy as jnp
import matplotlib
import numpy as np
from _common import RESULTS, print_table, timed, write_json

from jaxdpd.analysis.statistics import block_average
from jaxdpd.geometry.boxes import LeesEdwardsBox
from jaxdpd.solvents.lattice_boltzmann import counter_noise, lees_edwards
from jaxdpd.solvents.lattice_boltzmann.fluid import (
    FluidParameters,
    lattice_update,
    modes,
    thermal_deviations,
)

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

jax.config.update("jax_enable_x64", True)


def linear_translate(layer, shift):
    """ESPResSo's translation: linear interpolation between the two nearest nodes."""
    n = layer.shape[-2]
    whole = jnp.floor(shift)
    fraction = (shift - whole).astype(layer.dtype)
    source = (jnp.arange(n) + whole.astype(jnp.int32)) % n
    return (1 - fraction) * layer[..., source, :] + fraction * layer[..., (source + 1) % n, :]


def _nothing(f, density, velocity):
    return None


def layer_profiles(steps: int, translate) -> dict:
    """Per-layer u_x and temperature of the fluctuating sheared fluid."""
    lees_edwards.translate_layer, original = translate, lees_edwards.translate_layer
    try:
        nodes, shear_rate = (8, 16, 8), 0.0025
        box = LeesEdwardsBox((8.0, 16.0, 8.0), shear_rate)
        quiet = FluidParameters(nodes, 1.0, 1.0, 1.0, 0.1, 0.3, 0.0)
        settle = lees_edwards.fluid_run(quiet, box, jnp.float64, 3000, _nothing)
        laminar, _ = settle(jnp.zeros((19, *nodes), jnp.float64))
        fluid = FluidParameters(nodes, 1.0, 1.0, 1.0, 0.1, 0.3, 1e-4)
        thermal = thermal_deviations(fluid, np.random.default_rng(4), np.float64)

        def observe(f, density, velocity):
            m = modes(f - laminar)
            momentum = jnp.mean(jnp.sum(m[1:4] ** 2, axis=0), axis=(0, 2)) / 3
            return velocity[0].mean(axis=(0, 2)), momentum

        run = lees_edwards.fluid_run(fluid, box, jnp.float64, steps + 200, observe, seed=3)
        _, (velocity, momentum) = run(laminar + thermal)
    finally:
        lees_edwards.translate_layer = original
    expected = fluid.mode_variances[1] * (1 - 1 / fluid.n_nodes)
    u, u_error = block_average(np.asarray(velocity)[200:], n_blocks=20)
    t, t_error = block_average(np.asarray(momentum)[200:] / expected, n_blocks=20)
    heights = np.arange(nodes[1]) + 0.5 - nodes[1] / 2
    return {
        "y": (heights + nodes[1] / 2).tolist(),
        "u_x": np.asarray(u).tolist(),
        "u_x_error": np.asarray(u_error).tolist(),
        "laminar": (shear_rate * heights).tolist(),
        "temperature": np.asarray(t).tolist(),
        "temperature_error": np.asarray(t_error).tolist(),
    }


def step_cost(size: int) -> list[dict]:
    """Seconds per LB step of a thermal float32 fluid at rest and sheared."""
    nodes = (size, size, size)
    fluid = FluidParameters(nodes, 1.0, 1.0, 1.0, 0.1, 0.3, 1e-4)
    dtype = jnp.float32
    start = jnp.asarray(thermal_deviations(fluid, np.random.default_rng(0), np.float32))
    impulse = jnp.zeros((3, *nodes), dtype)
    box = LeesEdwardsBox((float(size),) * 3, 0.001)
    rows, chunk = [], 50
    for label, sheared in (("rest", False), ("steady shear", True)):
        update = lattice_update(
            fluid, dtype, "uniform", lees_edwards.sheared_stream if sheared else None
        )

        @jax.jit
        def run(f, update=update, sheared=sheared):
            def body(carry, lb_step):
                f, state = carry
                key = counter_noise.family_key(0, lb_step, counter_noise.LATTICE_SALT)
                edge = ()
                if sheared:
                    state = box.advance(state, None, 1.0)
                    edge = lees_edwards.boundary(box, state, 1.0, 1.0, dtype)
                return (update(f, impulse, key, edge)[0], state), None

            return jax.lax.scan(body, (f, box.initial_state(dtype)), jnp.arange(chunk))[0][0]

        timed(run, start)
        best = min(timed(run, start)[1] for _ in range(3))
        rows.append({"flow": label, "nodes": size**3, "seconds_per_step": best / chunk})
    for row in rows:
        row["relative_to_rest"] = row["seconds_per_step"] / rows[0]["seconds_per_step"]
        row["MLUPS"] = row["nodes"] / row["seconds_per_step"] / 1e6
    return rows


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--steps", type=int, default=4000)
    parser.add_argument("--size", type=int, default=32)
    args = parser.parse_args()
    profiles = {
        "spectral (jaxdpd)": layer_profiles(args.steps, lees_edwards.translate_layer),
        "linear (ESPResSo)": layer_profiles(args.steps, linear_translate),
    }
    rows = []
    for name, p in profiles.items():
        for j in (0, 1, 7, 14, 15):
            rows.append(
                {
                    "translation": name,
                    "layer": j,
                    "u_x": p["u_x"][j],
                    "laminar": p["laminar"][j],
                    "T/T0": p["temperature"][j],
                    "error": p["temperature_error"][j],
                }
            )
    print_table(["translation", "layer", "u_x", "laminar", "T/T0", "error"], rows)
    cost = step_cost(args.size)
    print_table(["flow", "nodes", "seconds_per_step", "relative_to_rest", "MLUPS"], cost)
    write_json(
        "lattice_boltzmann_shear",
        {"steps": args.steps, "profiles": profiles, "cost": cost},
    )
    figure, (left, right) = plt.subplots(1, 2, figsize=(9, 3.6))
    for (name, p), marker in zip(profiles.items(), "os", strict=True):
        left.errorbar(p["y"], p["u_x"], p["u_x_error"], fmt=marker, ms=4, label=name)
        right.errorbar(p["y"], p["temperature"], p["temperature_error"], fmt=marker, ms=4)
    first = next(iter(profiles.values()))
    left.plot(first["y"], first["laminar"], "k-", lw=0.8, label="γ̇ (y − L_y/2)")
    left.set(xlabel="y / a", ylabel="⟨u_x⟩ (a/τ)", title="velocity")
    right.axhline(1.0, color="k", lw=0.8)
    right.set(xlabel="y / a", ylabel="⟨δj²⟩ / (μ b₁)", title="layer temperature")
    left.legend(fontsize=8)
    figure.tight_layout()
    figure.savefig(RESULTS / "lattice_boltzmann_shear.png", dpi=120)


if __name__ == "__main__":
    main()
