"""One system over several devices: spatial decomposition into slabs.

A scene with `[parallel] devices = D` is cut into D slabs along one frame axis, one
per device; each device owns the particles in its slab, receives copies of its
neighbours' particles within a halo of its faces every step, runs the solvent's own
step on both, keeps its owned rows and hands over the particles that left.  Sums over
the system are collectives.  Modules:

    layout         the slabs, the halo width, the buffer sizes and their checks
    requirements   what a scene must satisfy to be decomposed
    slab_view      a device's part of the box, as the cell list sees it
    exchange       halo copies and migration between neighbouring devices (ppermute)
    forces         the force kernel of one device's rows
    simulation     `build_decomposed(scene)`: the decomposed Simulation and its state
    host_devices   CPU devices for a decomposed run on one host

docs/scaling_out.md explains when to decompose a system and when to shard an
ensemble instead, and what decomposition costs.
"""
