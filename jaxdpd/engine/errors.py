"""Error flags raised inside jitted steps and the exceptions the driver turns them into.

Flags are bits of an int32 in the state, OR-ed step by step (`jnp.where(bad,
StepError.NON_FINITE, 0)`); the driver reads them after each chunk and names the set
bits with `describe`.
"""

import enum

# A kinetic temperature this many times the set value means the integration is
# unstable (thermostatted DPD stays within a few per cent of it).  A
# Hoogerbrugge–Koelman fluid has no set value: its scale is solvent.initial_kT, the
# expected temperature of the fluid (jaxdpd.scene).
RUNAWAY_FACTOR = 100.0


class StepError(enum.IntFlag):
    """The error bits a step can set, each with the message the driver reports.

    Members are listed cause first, and `describe` keeps that order: a spring or
    fluid failure is named before the non-finite values it leads to.
    """

    message: str

    def __new__(cls, bit: int, message: str):
        member = int.__new__(cls, bit)
        member._value_ = bit
        member.message = message
        return member

    SPRING_OVERSTRETCHED = (
        8,
        "a FENE spring reached its maximum extension (|Q| ≥ Q0): the time step is too "
        "large for the spring's stiffness near full extension (reduce integrator.dt)",
    )
    SPRING_PAST_HALF_BOX = (
        16,
        "a spring became too long for its periodic image to be certain (longer than "
        "half a box edge where it is read by minimum image: a flowing box, "
        "spring_repulsion or the 'spring_pairs' observable): enlarge the box, or use "
        "finitely extensible (FENE) springs with max_extension below half the shortest "
        "edge",
    )
    FLUID_INVALID = (
        32,
        "the lattice-Boltzmann fluid reached a non-positive or non-finite density or "
        "velocity: the flow is too fast for the lattice (Mach number near 1) or the "
        "noise too strong for the node mass; reduce solvent.time_step, raise "
        "solvent.density or lower the forcing",
    )
    DOMAIN_REACH = (
        64,
        "in a decomposed run, a particle moved farther in one step than "
        "parallel.margin allows, or a bond grew longer than the halo (the longest "
        "reach, pair cut-off or FENE bond, plus parallel.margin): raise parallel.margin "
        "(slabs must stay at least one halo thick), use FENE springs, or reduce "
        "integrator.dt",
    )
    NEIGHBOR_OVERFLOW = 1, "neighbour list overflow (buffers too small)"
    NON_FINITE = (
        2,
        "non-finite positions, velocities or forces: the integration became unstable; "
        "the usual cause is a time step too large (reduce integrator.dt)",
    )
    TEMPERATURE_RUNAWAY = (
        4,
        f"kinetic temperature above {RUNAWAY_FACTOR:g}× its set value (solvent.kT, or "
        "solvent.initial_kT for hoogerbrugge_koelman): the integration is unstable; the "
        "usual cause is a time step too large (reduce integrator.dt); a "
        "Hoogerbrugge–Koelman fluid whose own temperature is far above initial_kT "
        "needs initial_kT near it",
    )


class SimulationError(RuntimeError):
    """A run stopped because the state became invalid; a checkpoint was written."""


def describe(flags: int) -> str:
    """The messages of the bits set in `flags` (an int or a StepError), cause first;
    bits no member names are ignored."""
    messages = [member.message for member in StepError(int(flags))]
    return "; ".join(messages) if messages else "no error"
