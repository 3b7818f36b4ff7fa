"""Helpers shared by the benchmark scripts: timing, tables, JSON results."""

import importlib.util
import json
import platform
import resource
import statistics
import time
from pathlib import Path

import jax
import jax.numpy as jnp

RESULTS = Path(__file__).resolve().parent / "results"


def machine() -> dict:
    """Where a figure was measured."""
    device = jax.devices()[0]
    return {
        "platform": platform.platform(),
        "processor": platform.processor() or platform.machine(),
        "jax_backend": device.platform,
        "device": str(device.device_kind),
        "cpu_count": __import__("os").cpu_count(),
        "cpu": cpu_description(),
        "jax": jax.__version__,
    }


def cpu_description() -> dict:
    """The CPU's model, family, cache and widest x86 vector extension from the first
    processor in /proc/cpuinfo ({} where there is none; "cache size" is the L2 per core
    on AMD, the L3 on Intel): machines of one name differ (an AVX2 and an AVX-512 EPYC
    ran the same benchmarks a factor of two apart), so results say which one they came
    from."""
    try:
        first = Path("/proc/cpuinfo").read_text().split("\n\n")[0]
    except OSError:
        return {}
    fields = dict(
        (key.strip(), value.strip())
        for key, _, value in (line.partition(":") for line in first.splitlines())
    )
    flags = fields.get("flags", "").split()
    keys = ("model name", "cpu family", "model", "cache size")
    description = {key: fields[key] for key in keys if key in fields}
    vector = [name for name in ("avx512f", "avx2", "sse4_2") if name in flags]
    if vector:
        description["vector"] = vector[0]
    return description


def peak_rss_mib() -> float:
    """Peak resident set size of this process so far (MiB)."""
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024


def timed(function, *args):
    """(result, seconds) of a call whose result is a JAX pytree (blocked on)."""
    start = time.perf_counter()
    result = function(*args)
    jax.block_until_ready(result)
    return result, time.perf_counter() - start


def copy_bandwidth(shape, dtype, steps: int) -> float:
    """Bytes/s of a jitted read-modify-write pass (`x + 1`, read + write) over an array
    of `shape`, repeated `steps` times in a scan: the memory bandwidth a one-pass
    kernel over that much data can reach here, measured in the caller's process."""
    x = jnp.zeros(shape, dtype)
    run = jax.jit(lambda x: jax.lax.scan(lambda c, _: (c + 1, None), x, None, length=steps)[0])
    run(x).block_until_ready()
    _, seconds = timed(run, x)
    return 2 * x.size * x.dtype.itemsize * steps / seconds


def best_of(function, repeats: int) -> float:
    """The shortest of `repeats` wall times (s) of `function()`: the run least
    disturbed by the rest of the machine."""
    times = []
    for _ in range(repeats):
        start = time.perf_counter()
        function()
        times.append(time.perf_counter() - start)
    return min(times)


def module_from_file(path: Path, name: str):
    """The Python module at `path`, imported under `name`: e.g. a base tree's copy of
    a jaxdpd module, loaded beside this tree's for an A/B comparison."""
    spec = importlib.util.spec_from_file_location(name, path)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def compiled_chunk(scene, state, steps: int, replacements=()):
    """(the driver's compiled chunk of `scene`, the state it starts from): `state`, or
    the scene's initial state if None.  Each (module, name, value) of `replacements` is
    in place while the step is built and compiled, and restored after, so that an A/B
    benchmark can compile a base variant beside this tree's.  `build` is cached per
    scene, so its uncached function is called."""
    from jaxdpd.engine.build import build
    from jaxdpd.run import driver

    saved = [(module, name, getattr(module, name)) for module, name, _ in replacements]
    for module, name, value in replacements:
        setattr(module, name, value)
    try:
        simulation = build.__wrapped__(scene)
        state = simulation.init_fn() if state is None else state
        return driver._scan_chunk.lower(simulation.step_fn, state, steps).compile(), state
    finally:
        for module, name, value in saved:
            setattr(module, name, value)


def alternating_rates(runs: dict, work: float, rounds: int) -> dict:
    """{label: [work per second, one per round]} of the argument-free callables in
    `runs` (their results blocked on), each timed once per round, in reverse order
    every other round, so that the load of a shared machine hits them alike."""
    rates = {label: [] for label in runs}
    for index in range(rounds):
        order = list(runs) if index % 2 == 0 else list(runs)[::-1]
        for label in order:
            start = time.perf_counter()
            jax.block_until_ready(runs[label]())
            rates[label].append(work / (time.perf_counter() - start))
    return rates


def ratio_summary(rates: dict, this: str = "this", base: str = "base") -> str:
    """'this/base median R (rounds: r1 r2 ...)' of `alternating_rates`' output: the
    rounds' spread is the noise a difference must exceed."""
    ratios = [a / b for a, b in zip(rates[this], rates[base], strict=True)]
    rounds = " ".join(f"{r:.2f}" for r in ratios)
    return f"{this}/{base} median {statistics.median(ratios):.2f} (rounds: {rounds})"


def print_table(columns, rows) -> None:
    """Print rows (dicts) under the given column names."""
    widths = [max(len(c), *(len(_fmt(r.get(c))) for r in rows)) for c in columns]
    print("  ".join(c.rjust(w) for c, w in zip(columns, widths, strict=True)))
    for row in rows:
        print("  ".join(_fmt(row.get(c)).rjust(w) for c, w in zip(columns, widths, strict=True)))


def _fmt(value) -> str:
    if isinstance(value, float):
        return f"{value:.4g}"
    return "" if value is None else str(value)


def write_json(name: str, payload: dict) -> Path:
    """Write benchmarks/results/<name>.json with the machine description added."""
    RESULTS.mkdir(parents=True, exist_ok=True)
    path = RESULTS / f"{name}.json"
    path.write_text(json.dumps({"machine": machine(), **payload}, indent=2))
    return path


def dumbbell_demo(count: int = 3000):
    """The scene the I/O benchmarks measure (the demo until it became a plain fluid):
    FENE dumbbells (b = H Q0²/k_BT = 50, Q0 = 4) at 25 % of the particles of the
    demo's Groot–Warren DPD solvent, float32, with per-step conformation, on-device
    chain correlators and g(r)."""
    from jaxdpd.run.cli import demo_scene

    species = [{"name": "dumbbell", "fraction": 0.25}, {"name": "solvent", "fraction": 0.75}]
    bond = {"law": "fene", "spring_constant": 3.125, "max_extension": 4.0}
    return demo_scene().replace(
        particles={"count": count, "species": species},
        polymers=[{"species": "dumbbell", "beads": 2, "bond": bond}],
        pair={"kind": "soft_repulsion", "a": 25.0},
        output={"observables": ["temperature", "pressure", "conformation", "dynamics", "rdf"]},
    )
