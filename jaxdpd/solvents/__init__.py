"""Solvent methods: Groot–Warren DPD, Lowe–Andersen, Hoogerbrugge–Koelman, MPCD and
lattice Boltzmann, each a `SolventMethod` component (jaxdpd.solvents.component)
registered here under the name a scene gives as solvent.method."""

from jaxdpd.registry import Registry
from jaxdpd.solvents.component import SolventMethod, SolventParameters, StepContext
from jaxdpd.solvents.groot_warren import GrootWarren
from jaxdpd.solvents.hoogerbrugge_koelman import HoogerbruggeKoelman
from jaxdpd.solvents.lattice_boltzmann.method import LatticeBoltzmann
from jaxdpd.solvents.lowe_andersen import LoweAndersen
from jaxdpd.solvents.mpcd.method import MPCD

SOLVENTS: Registry[SolventMethod] = Registry("solvent method", "solvent.method")
SOLVENTS.register(GrootWarren())
SOLVENTS.register(HoogerbruggeKoelman())
SOLVENTS.register(LoweAndersen())
SOLVENTS.register(LatticeBoltzmann())
SOLVENTS.register(MPCD())

__all__ = ["SOLVENTS", "SolventMethod", "SolventParameters", "StepContext"]
