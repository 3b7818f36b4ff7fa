"""Resource limits of a scene, checked by `build()` before anything is allocated.

A scene whose sizes are each valid can still ask for more than a machine holds
(`particles.count = 1e9`, `output.rdf_bins = 1e12`), overflow the int32 arithmetic
of step counters and buffer indices (`run.steps ≥ 2³¹`,
`neighbors.capacity_multiplier = 1e7`), or crowd so many particles into one
neighbour cell that tracing the cell list's per-slot loop never ends (3000
particles in a 2.1³ box), or shear so fast that the Lees–Edwards offset moves by half
a box in one step (its image bookkeeping assumes less).  Each of these is refused
here with a `ResourceError` (a ValueError) that names the field responsible, its
value and what would fit.

The memory estimate is a lower bound: it counts only arrays every such run holds
(particle arrays, the pair buffer, the per-chunk series of each requested
observable, histograms, correlators, solvent grids), so a refused scene cannot fit,
while a scene that passes may still need a few times more (temporaries, compiled
code).
"""

import math
import os

import numpy as np

from jaxdpd.observables import scene_observables
from jaxdpd.validation import INT32_MAX

# Mean particles per neighbour cell above which the cell list is refused: its distance
# test is unrolled over the slots of a cell at trace time (a DPD fluid at ρ = 3 has
# 3 per cell; an MPCD fluid at ρ = 10 with a cell of 1.5 r_c some 34).
MAX_CELL_OCCUPANCY = 256


class ResourceError(ValueError):
    """A scene that needs more memory, or larger integers, than it may have."""


def available_memory() -> int:
    """Bytes of memory available to a new allocation: /proc/meminfo MemAvailable (Linux),
    else the physical pages free (os.sysconf), else no limit."""
    try:
        with open("/proc/meminfo") as meminfo:
            for line in meminfo:
                if line.startswith("MemAvailable:"):
                    return int(line.split()[1]) * 1024
    except OSError:
        pass
    try:
        return os.sysconf("SC_AVPHYS_PAGES") * os.sysconf("SC_PAGE_SIZE")
    except (ValueError, OSError, AttributeError):
        return INT32_MAX**2


def pair_capacity(scene, box_volume: float) -> float:
    """The pair buffer the first allocation asks for (jaxdpd.geometry.neighbors): the ideal-gas
    count ½N(N−1)(4π/3)(r_c + skin)³/V times neighbors.capacity_multiplier, or every
    pair N(N−1)/2 for neighbors.method = "all_pairs"."""
    n = scene.n_particles
    if scene.neighbors.method == "all_pairs":
        return 0.5 * n * (n - 1)
    reach = scene.cutoff + scene.neighbors.skin
    ideal = 0.5 * n * (n - 1) * 4 / 3 * math.pi * reach**3 / box_volume
    return ideal * scene.neighbors.capacity_multiplier


def estimated_bytes(scene, box) -> dict:
    """Lower bounds of the memory a run of `scene` holds, by the field that sets each.

    Args:
        scene: a validated Scene.
        box: its static box (jaxdpd.geometry.boxes).
    Returns:
        dict field name → bytes (float, inf where a size overflows a float).
    """
    box_volume = box.volume
    f = np.dtype(scene.precision).itemsize
    n = scene.n_particles
    chunk = scene.run.chunk
    # Positions, velocities, forces (3 floats each), image counters and species.
    sizes = {"particles.count": n * (9 * f + 16)}
    if scene.pair is not None or scene.solvent_component.uses_neighbor_list:
        sizes["neighbors.capacity_multiplier"] = 8 * pair_capacity(scene, box_volume)
        if scene.neighbors.method == "cell_list":
            # The cell grid: at least three int32 member slots per cell.
            sizes["box.lengths"] = 12 * cell_count(scene, box)
    # Each chunk's per-step series are stacked on device and copied to the host: one
    # value per step at least, and what each observable holds beyond it.
    sizes["run.chunk"] = chunk * f
    for component in scene_observables(scene):
        for field, size in component.memory(scene, f).items():
            sizes[field] = sizes.get(field, 0) + size
    sizes.update(scene.solvent_component.memory(scene, box_volume, f))
    return sizes


def check_resources(scene, box, available: int | None = None) -> None:
    """Refuse a scene that cannot run here (see the module docstring).

    Args:
        scene: a validated Scene.
        box: its static box (jaxdpd.geometry.boxes), for the cell grid.
        available: bytes available (default: `available_memory()`).
    Raises:
        ResourceError naming the field.
    """
    run = scene.run
    if run.steps + run.equilibration > INT32_MAX:
        raise ResourceError(
            f"run.steps + run.equilibration = {run.steps + run.equilibration}: the step "
            f"counter is int32; at most {INT32_MAX} steps in all (continue a longer run "
            "from its checkpoint in a new file)"
        )
    _check_cell_occupancy(scene, box)
    _check_offset_step(scene)
    sizes = estimated_bytes(scene, box)
    total = sum(sizes.values())
    available = available_memory() if available is None else available
    if total > available:
        field, largest = max(sizes.items(), key=lambda item: item[1])
        raise ResourceError(
            f"{field}: the scene needs at least {total / 2**30:.3g} GiB "
            f"({field} accounts for {largest / 2**30:.3g} GiB), more than the "
            f"{available / 2**30:.3g} GiB of memory available; reduce {field}"
        )
    capacity = pair_capacity(scene, box.volume)
    if capacity > INT32_MAX:
        field = f"particles.count = {scene.n_particles} with " + (
            "neighbors.method = 'all_pairs'"
            if scene.neighbors.method == "all_pairs"
            else f"neighbors.capacity_multiplier = {scene.neighbors.capacity_multiplier:g}"
        )
        raise ResourceError(
            f"{field}: the pair buffer would hold {capacity:.3g} pairs, more than the "
            f"int32 indices allow ({INT32_MAX}); use a multiplier near 1.25 (the buffer "
            "grows by itself on overflow), fewer particles, or neighbors.method = "
            "'cell_list'"
        )


def cell_count(scene, box) -> float:
    """Cells of the neighbour grid of a cell-list scene (a float), capped as the cell
    list caps them (at most 4 per particle)."""
    from jaxdpd.geometry.neighbors.cell_list import cell_grid

    reach = scene.cutoff + scene.neighbors.skin
    return math.prod(float(n) for n in cell_grid(box, reach, scene.n_particles))


def _check_cell_occupancy(scene, box) -> None:
    """Refuse cell-list scenes whose cells would hold more than MAX_CELL_OCCUPANCY
    particles on average."""
    if scene.neighbors.method != "cell_list":
        return
    reach = scene.cutoff + scene.neighbors.skin
    cells = cell_count(scene, box)
    occupancy = scene.n_particles / cells
    if occupancy > MAX_CELL_OCCUPANCY:
        raise ResourceError(
            f"particles.count = {scene.n_particles} in box.lengths = "
            f"{list(box.lengths)}: {occupancy:.0f} particles per neighbour cell on "
            f"average ({cells:.0f} cells of at least r_c + skin = {reach:g}), more than "
            f"{MAX_CELL_OCCUPANCY}; lower the density, enlarge the box (three cells "
            "per axis need edges ≥ 3 (r_c + skin)), or use neighbors.method = 'all_pairs'"
        )


def _check_offset_step(scene) -> None:
    """Refuse a shear whose Lees–Edwards offset moves by L_x/2 or more in one step: the
    image counters are carried across the offset's wraps by reading them from its
    change (LeesEdwardsBox.carry_images), which needs |γ̇| L_y Δt < L_x/2."""
    flow = scene.flow
    if flow is None or flow.kind != "shear":
        return
    lx, ly, _ = scene.box.lengths
    shift = abs(flow.shear_rate) * ly * scene.step_time
    if not shift < 0.5 * lx:
        raise ResourceError(
            f"flow.shear_rate = {flow.shear_rate:g}: the Lees–Edwards offset would move by "
            f"|γ̇| L_y Δt = {shift:.4g} per step, at least half of L_x = {lx:g}; lower the "
            "shear rate or the time step (a step that long cannot be integrated anyway)"
        )
