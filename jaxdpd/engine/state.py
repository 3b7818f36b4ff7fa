"""The simulation state: a pytree that a step function maps to its successor."""

import jax.numpy as jnp

from jaxdpd import pytree
from jaxdpd.geometry.neighbors import PairList


@pytree.dataclass
class SimState:
    """Everything a step needs, and nothing module-level.

    Attributes:
        positions: (N, 3) wrapped into the box.
        velocities: (N, 3).
        forces: (N, 3) forces at the current positions (velocity-Verlet scheme);
            zeros for solvents that have no force (Hoogerbrugge–Koelman).
        image: (N, 3) int32 periodic image counters (unwrapped = r + image · L).
        species: (N,) int32 species index.
        pair_list: neighbour pairs.
        virial: (3, 3) virial Σ r_ij ⊗ F_ij of the last step's pair forces
            (zeros unless the scene asks for the pressure).
        step: int32 step counter (also the counter of the pair noise).
        time: simulated time.
        seed: uint32 seed of the counter-based noise.
        flags: int32 error bits (see jaxdpd.engine.errors).
        solvent_state: state a solvent method keeps beside the particles (e.g. a
            lattice-Boltzmann fluid, or the Lowe–Andersen thermostat's record of its
            last sweep), a pytree; None for other particle solvents.
        box_state: traced state of a flowing box (e.g. the Lees–Edwards offset and
            shear rate); None for a box at rest.
        observers: accumulators of observables measured on device while the run goes
            (e.g. multiple-tau correlators), a dict pytree; None when none is asked.
        parameters: traced model parameters read by the force kernels (bond
            constants, body-force amplitude; see jaxdpd.engine.parameters), a dict pytree;
            change them without recompiling, or give each replica its own.
        spring_pairs: the spring-pair list (jaxdpd.geometry.neighbors.spring_pair_list) of scenes
            with spring–spring repulsion or the "spring_pairs" observable; else None.
    """

    positions: jnp.ndarray
    velocities: jnp.ndarray
    forces: jnp.ndarray
    image: jnp.ndarray
    species: jnp.ndarray
    pair_list: PairList
    virial: jnp.ndarray
    step: jnp.ndarray
    time: jnp.ndarray
    seed: jnp.ndarray
    flags: jnp.ndarray
    solvent_state: object = None
    box_state: object = None
    observers: object = None
    parameters: object = None
    spring_pairs: object = None
