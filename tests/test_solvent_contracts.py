"""Contract tests of every registered solvent method (jaxdpd.solvents.SOLVENTS).

Each test is parametrised over the registry and runs the method's own small example
scene (`SolventMethod.example_scene`), so a method registered later gets all of them
by providing one.  For every method:

- the particles' total momentum is constant to round-off where the method claims it
  (`conserves_particle_momentum`), and is not asserted otherwise;
- equipartition: the three Cartesian kinetic temperatures agree within their
  statistical error, and match solvent.kT where the method `sets_temperature`;
- a float32 scene stays float32 in every floating leaf of the state;
- a vmapped batch of two replicas (different seeds) equals the replicas run alone;
- a restart through the checkpoint store (jaxdpd.io write_tree / read_tree) is
  bit-identical to the run that went straight on;
- an unknown key in [solvent] is a SceneError naming the field.

All runs go through the driver's jitted chunk (jaxdpd.run.driver.run_chunk, which
vmaps a batch) with one chunk length, so each method compiles its step
once per precision plus once vmapped.
"""

import math
from types import SimpleNamespace

import h5py
import jax
import numpy as np
import pytest

from jaxdpd.engine.build import build
from jaxdpd.io import read_tree, write_tree
from jaxdpd.run import driver, ensemble
from jaxdpd.scene import Scene
from jaxdpd.solvents import SOLVENTS
from jaxdpd.validation import SceneError

CHUNK = 5  # steps per jitted chunk
EQUILIBRATION = 20  # chunks before the first sample: the random start relaxes
SAMPLES = 4  # states sampled after it, SPACING chunks apart
SPACING = 5
# Standard deviations a statistical check allows: a Gaussian deviation beyond 4σ has
# probability 6e-5, so the ~20 comparisons of this file fail by chance with
# probability below 2e-3 (and never flakily: every seed is fixed).
Z = 4.0

METHODS = list(SOLVENTS)
IDS = [method.name for method in METHODS]


def advance(simulation, state, chunks: int = 1):
    """`chunks` × CHUNK steps through the driver (overflow reallocation included)."""
    for _ in range(chunks):
        state, _, _ = driver.run_chunk(simulation, state, CHUNK)
    return state


@pytest.fixture(scope="module", params=METHODS, ids=IDS)
def run(request):
    """The method's float64 example scene, built: its initial state, its state after
    EQUILIBRATION chunks and SAMPLES states SPACING chunks apart after that."""
    method = request.param
    scene = Scene.from_dict(method.example_scene("float64"))
    simulation = build(scene)
    start = simulation.init_fn()
    states = [advance(simulation, start, EQUILIBRATION)]
    for _ in range(SAMPLES):
        states.append(advance(simulation, states[-1], SPACING))
    return SimpleNamespace(
        method=method, scene=scene, simulation=simulation, start=start, states=states
    )


def masses_of(simulation, n: int) -> np.ndarray:
    if simulation.masses is None:
        return np.ones(n)
    return np.asarray(simulation.masses, float)


def momentum(simulation, state) -> np.ndarray:
    velocities = np.asarray(state.velocities, float)
    return masses_of(simulation, velocities.shape[0]) @ velocities


def momentum_round_off(simulation, scene, states, steps: int) -> float:
    """The bound on the round-off drift of Σ m v over `steps` steps derived in
    `test_momentum_conserved_where_claimed`: steps · 100 ε N p_scale, p_scale the
    largest m|v| + Δt_step |F| over `states`."""
    masses = masses_of(simulation, scene.n_particles)
    scale = max(
        float(np.max(masses * np.linalg.norm(np.asarray(s.velocities, float), axis=1)))
        + scene.step_time * float(np.max(np.linalg.norm(np.asarray(s.forces, float), axis=1)))
        for s in states
    )
    return steps * 100 * np.finfo(np.float64).eps * scene.n_particles * scale


def test_example_scene_is_valid_and_round_trips(run):
    """The example scene is valid and its resolved form reads back to itself."""
    assert run.scene.solvent.method == run.method.name
    assert Scene.from_dict(run.scene.to_dict()) == run.scene
    assert all(int(state.flags) == 0 for state in [run.start, *run.states])


def test_momentum_conserved_where_claimed(run):
    """Σ m v is constant to float64 round-off where the method conserves it.

    Error estimate: every step rounds each particle's velocity update, of size
    |Δv| ≤ |v| + Δt_step |F| / m, at relative ε = 2⁻⁵², and the force sums themselves
    (Σ_j F_ij cancels only exactly); summed over N particles, with the worst case of
    all roundings adding up, |ΔP| ≤ c ε N p_scale per step with p_scale the largest
    m|v| + Δt_step Σ|F_ij| ≈ m|v| + Δt_step |F| n_pairs.  We take c n_pairs = 100 (a
    particle has ≲ 40 neighbours within r_c at ρ = 3, plus the bonds) and the
    steps run.  Measured (this machine): drifts 3·10⁻¹⁵ (Hoogerbrugge–Koelman) to
    1.4·10⁻¹³ (MPCD) against bounds 2·10⁻¹⁰ to 10⁻⁸; a broken pair symmetry gives
    drifts of order the forces themselves.
    """
    if not run.method.conserves_particle_momentum:
        pytest.skip(f"{run.method.name} does not claim particle momentum conservation")
    simulation, states = run.simulation, [run.start, *run.states]
    steps = CHUNK * (EQUILIBRATION + SAMPLES * SPACING)
    tolerance = momentum_round_off(simulation, run.scene, states, steps)
    start = momentum(simulation, states[0])
    for state in states[1:]:
        drift = np.max(np.abs(momentum(simulation, state) - start))
        assert drift < tolerance, (drift, tolerance)


def kinetic_temperatures(simulation, state) -> np.ndarray:
    """(3,) T_a = Σ m (v_a − V_a)² / (N − 1), V the centre-of-mass velocity: unbiased
    for Maxwellian velocities whether or not the total momentum was set to zero."""
    velocities = np.asarray(state.velocities, float)
    masses = masses_of(simulation, velocities.shape[0])
    centre = masses @ velocities / masses.sum()
    return masses @ (velocities - centre) ** 2 / (velocities.shape[0] - 1)


def test_equipartition(run):
    """The Cartesian kinetic temperatures agree, and equal solvent.kT where it is set.

    Reference: for Maxwellian velocities each m v_a²/k_BT is χ²₁, so T_a over N
    particles (N − 1 degrees of freedom after the centre of mass) has relative
    standard deviation √(2/(N − 1)) (e.g. Allen & Tildesley, Computer Simulation of
    Liquids, §2.4), independently for a = x, y, z.  After the equilibration (the
    random start's overlaps heat a DPD fluid to T ≈ 1.5 in its first 20 steps) we
    average SAMPLES states; they are correlated, and the standard deviation of a
    mean of correlated samples is at most that of one sample, so √(2/(N − 1)) bounds
    it.  A difference of two axes has at most √2 times that; the mean of the three
    axes at most 1/√3 of it.  Allowed: Z of these.
    """
    samples = np.array([kinetic_temperatures(run.simulation, s) for s in run.states])
    mean = samples.mean(axis=0)
    scale = float(mean.mean())
    relative = math.sqrt(2 / (run.scene.n_particles - 1))
    for a in range(3):
        for b in range(a + 1, 3):
            assert abs(mean[a] - mean[b]) < Z * math.sqrt(2) * relative * scale, mean
    if run.method.sets_temperature:
        kT = run.scene.solvent.kT
        assert abs(scale - kT) < Z * relative / math.sqrt(3) * kT, (scale, kT)


def floating_leaves(tree) -> list:
    return [
        (jax.tree_util.keystr(path), leaf.dtype)
        for path, leaf in jax.tree_util.tree_leaves_with_path(tree)
        if np.issubdtype(leaf.dtype, np.floating)
    ]


@pytest.mark.parametrize("method", METHODS, ids=IDS)
def test_float32_stays_float32(method):
    """A float32 scene keeps every floating leaf of its state and samples in float32
    (64-bit JAX is on in the test session, so a stray float64 would show)."""
    simulation = build(Scene.from_dict(method.example_scene("float32")))
    state = simulation.init_fn()
    state, samples, _ = driver.run_chunk(simulation, state, CHUNK)
    leaves = floating_leaves(state) + floating_leaves(samples)
    assert leaves
    wide = [(name, dtype) for name, dtype in leaves if dtype != np.float32]
    assert not wide, wide


# Compiling the vmapped step of a pair-force method takes 35–50 s on 2 cores; for
# these the check runs under -m slow (tests/test_ensemble.py checks a DPD batch
# against its replicas in the default run).  A method registered later runs it
# by default.
SLOW_BATCH = ("dpd", "lowe_andersen", "hoogerbrugge_koelman")


@pytest.mark.parametrize(
    "run",
    [
        pytest.param(m, id=m.name, marks=[pytest.mark.slow] if m.name in SLOW_BATCH else [])
        for m in METHODS
    ],
    indirect=True,
)
def test_vmapped_batch_equals_replicas(run):
    """Two replicas with different seeds, advanced as one vmapped batch, equal the
    same replicas advanced one at a time.

    Integer leaves (images, steps, lists, flags) agree exactly.  Floating leaves may
    differ in round-off: XLA orders the reductions of a vmapped step differently (a
    sum of n terms is then rounded differently by ≲ ε Σ|terms|, ε = 2⁻⁵²), measured
    at ≤ 2 ε of a leaf's scale after CHUNK steps (virial parts of DPD and
    Hoogerbrugge–Koelman, bead forces of lattice Boltzmann); positions and
    velocities of DPD and Hoogerbrugge–Koelman agree bit for bit.  Allowed: 8 ε per step
    of the leaf's largest |value|, far below any mixing of replicas (O(1)).
    """
    simulation, start = run.simulation, run.states[0]
    seeds = [int(start.seed) + 11, int(start.seed) + 12]
    batch = ensemble.replicate(simulation, start, seeds=seeds)
    batch, _, _ = driver.run_chunk(simulation, batch, CHUNK)
    replicas = ensemble.unstack(ensemble.replicate(simulation, start, seeds=seeds))
    alone = [advance(simulation, replica) for replica in replicas]
    for k, (together, single) in enumerate(zip(ensemble.unstack(batch), alone, strict=True)):
        assert jax.tree.structure(together) == jax.tree.structure(single)
        paths = jax.tree_util.tree_leaves_with_path(together)
        for (path, a), b in zip(paths, jax.tree.leaves(single), strict=True):
            a, b = np.asarray(a), np.asarray(b)
            where = f"replica {k}{jax.tree_util.keystr(path)}"
            if np.issubdtype(a.dtype, np.floating) and a.size:
                scale = float(np.max(np.abs(b)))
                tolerance = 8 * CHUNK * np.finfo(a.dtype).eps * scale
                np.testing.assert_allclose(a, b, rtol=0, atol=tolerance, err_msg=where)
            else:
                np.testing.assert_array_equal(a, b, err_msg=where)
    assert not np.array_equal(alone[0].velocities, replicas[0].velocities)


def test_restart_is_bit_identical(run, tmp_path):
    """The state after (SPACING − 1) chunks of sampling written with write_tree and
    read back into a fresh template (the initial state), one chunk more: the same
    bits as the run that went straight on (run.states[1])."""
    simulation, straight = run.simulation, run.states[1]
    middle = advance(simulation, run.states[0], SPACING - 1)
    with h5py.File(tmp_path / "state.h5", "w") as file:
        write_tree(file.create_group("state"), middle)
    with h5py.File(tmp_path / "state.h5", "r") as file:
        restored = read_tree(file["state"], simulation.init_fn())
    resumed = advance(simulation, restored)
    assert jax.tree.structure(resumed) == jax.tree.structure(straight)
    paths = jax.tree_util.tree_leaves_with_path(resumed)
    for (path, a), b in zip(paths, jax.tree.leaves(straight), strict=True):
        np.testing.assert_array_equal(np.asarray(a), np.asarray(b), jax.tree_util.keystr(path))


@pytest.mark.parametrize("method", METHODS, ids=IDS)
def test_unknown_solvent_field_is_named(method):
    """An unknown key in [solvent] is a SceneError whose field is the solvent section."""
    data = method.example_scene("float64")
    data["solvent"]["no_such_field"] = 1.0
    with pytest.raises(SceneError, match="no_such_field") as caught:
        Scene.from_dict(data)
    assert caught.value.field.startswith("solvent")


# -- flows -----------------------------------------------------------------------------
# Each flow a method declares (`SolventMethod.flows`; oscillatory shear with every shear
# step) runs its example scene; each flow it does not declare is refused by name.  The
# tests check the bookkeeping of the flowing box, not its physics (that is in each
# method's own flow tests, docs/solvent_flows/README.md), so the rates are gentle in
# each method's own time unit: STRAIN_PER_STEP of strain per step.
STRAIN_PER_STEP = 0.002
FLOWS = {
    "shear": {"kind": "shear"},
    "oscillatory_shear": {"kind": "shear", "oscillation_frequency": 0.5},
    "planar_elongation": {"kind": "planar_elongation"},
}
RATE_FIELDS = {"shear": "shear_rate", "planar_elongation": "elongation_rate"}
FLOW_STEPS = 4 * CHUNK


def enlarged(data: dict) -> dict:
    """The scene with its box edges doubled and its particle counts times 8: the example
    boxes are too thin for their springs in a Kraynik–Reinelt lattice, whose reduced cell
    is thinner than its edge (a spring must stay within half the thinnest height)."""
    particles = data["particles"]
    particles["count"] = 8 * particles["count"]
    for species in particles.get("species", []):
        if "count" in species:
            species["count"] = 8 * species["count"]
    if "lengths" in data.get("box", {}):
        data["box"]["lengths"] = [2 * edge for edge in data["box"]["lengths"]]
    return data


def flow_scene_dict(method, flow: str) -> dict:
    """The method's float64 example scene in `flow` (with the cell list, the only
    neighbour search that knows the Lees–Edwards and Kraynik–Reinelt boundaries)."""
    data = method.example_scene("float64")
    step_time = Scene.from_dict(data).step_time
    kind = FLOWS[flow]["kind"]
    data["flow"] = {**FLOWS[flow], RATE_FIELDS[kind]: STRAIN_PER_STEP / step_time}
    data["neighbors"] = {**data.get("neighbors", {}), "method": "cell_list"}
    return enlarged(data) if kind == "planar_elongation" else data


def declares(method, flow: str) -> bool:
    return FLOWS[flow]["kind"] in method.flows


FLOW_CASES = [(m, f) for m in METHODS for f in FLOWS]


@pytest.mark.slow
@pytest.mark.parametrize(
    ("method", "flow"), [c for c in FLOW_CASES if declares(*c)], ids=lambda x: getattr(x, "name", x)
)
def test_declared_flow_runs_and_conserves_peculiar_momentum(method, flow):
    """The example scene runs FLOW_STEPS steps in the flow without an error flag, the box
    clock advances by the simulated time, and where the method conserves momentum the
    total peculiar momentum Σ m c stays at its start to round-off (the bound and its
    derivation of `test_momentum_conserved_where_claimed`: a Lees–Edwards or
    Kraynik–Reinelt image exchanges the streaming velocity, not peculiar momentum)."""
    scene = Scene.from_dict(flow_scene_dict(method, flow))
    simulation = build(scene)
    start = simulation.init_fn()
    final = advance(simulation, start, FLOW_STEPS // CHUNK)
    assert int(final.flags) == 0
    assert int(final.step) == FLOW_STEPS
    assert float(final.time) == pytest.approx(FLOW_STEPS * scene.step_time, rel=1e-12)
    for leaf in (final.positions, final.velocities):
        assert np.all(np.isfinite(np.asarray(leaf)))
    if method.conserves_particle_momentum:
        tolerance = momentum_round_off(simulation, scene, (start, final), FLOW_STEPS)
        drift = np.max(np.abs(momentum(simulation, final) - momentum(simulation, start)))
        assert drift < tolerance, (drift, tolerance)


@pytest.mark.parametrize(
    ("method", "flow"),
    [c for c in FLOW_CASES if not declares(*c)],
    ids=lambda x: getattr(x, "name", x),
)
def test_undeclared_flow_is_refused_naming_the_fields(method, flow):
    with pytest.raises(SceneError) as raised:
        Scene.from_dict(flow_scene_dict(method, flow))
    message = str(raised.value)
    assert "flow.kind" in message and "solvent.method" in message
