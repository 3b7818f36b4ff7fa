"""What a scene must satisfy to be decomposed over devices, checked when it is read."""

from jaxdpd.decomposition.layout import check_slabs, slab_axis
from jaxdpd.geometry.boxes import make_box
from jaxdpd.geometry.chain_topology import chain_blocks
from jaxdpd.observables import OBSERVABLES
from jaxdpd.solvents import SOLVENTS


def halo_width(scene) -> float:
    """h = the reach of what acts between two particles, plus parallel.margin.

    The reach is the pair range (interaction or thermalisation cut-off) or the
    longest bond a finitely extensible law allows, whichever is longer: a bead's
    chain neighbours must be among the rows its device holds.  A bond without a
    maximum extension (Hookean, harmonic) must stay within the halo, or the run
    stops (StepError.DOMAIN_REACH), as LAMMPS stops with "bond atoms missing" when a
    bond outgrows its communication cut-off.
    """
    _, reach = scene.solvent_component.pair_range(scene.solvent, scene.cutoff)
    for block in chain_blocks(scene):
        extension = block.law.max_extension
        if extension is not None:
            reach = max(reach, float(extension))
    return reach + scene.parallel.margin


def check_scene(scene) -> None:
    """Refuse a [parallel] section the rest of the scene cannot run with, naming the
    field and what would do (only with parallel.devices > 1)."""
    devices = scene.parallel.devices
    method = scene.solvent_component
    if method.decomposition is None:
        decomposable = [m.name for m in SOLVENTS if m.decomposition is not None]
        raise ValueError(
            f"parallel.devices = {devices}: solvent.method = {method.name!r} cannot be "
            f"decomposed over devices; methods that can: {decomposable} "
            "(docs/scaling_out.md says why the others cannot yet)"
        )
    refused = [name for name in scene.output.observables if not OBSERVABLES.get(name).decomposes]
    if refused:
        measured = [c.name for c in OBSERVABLES if c.decomposes]
        raise ValueError(
            f"output.observables: {refused} are not measured in a decomposed run "
            f"(parallel.devices = {devices}); available there: {measured} "
            "(docs/scaling_out.md, 'Observables', says what the others would take)"
        )
    if scene.spring_repulsion is not None:
        raise ValueError(
            f"spring_repulsion: not available in a decomposed run (parallel.devices = {devices})"
        )
    if scene.body_force is not None and scene.body_force.kind != "cosine":
        raise ValueError(
            f"body_force.kind = {scene.body_force.kind!r}: a decomposed run applies only "
            "the 'cosine' body force (parallel.devices = "
            f"{devices})"
        )
    heavy = [s.name for s in scene.particles.species if s.mass != 1.0]
    if heavy:
        raise ValueError(
            f"particles.species {heavy}: a decomposed run needs unit masses "
            f"(parallel.devices = {devices})"
        )
    if scene.neighbors.method != "cell_list":
        raise ValueError(
            f"neighbors.method = {scene.neighbors.method!r}: a decomposed run searches "
            "with the cell list; use neighbors.method = 'cell_list'"
        )
    box = make_box(scene.box.kind, scene.box.lengths, scene.flow)
    axis = slab_axis(box, scene.parallel.axis)
    check_slabs(devices, axis, box.lengths[axis], halo_width(scene))
