"""Longest relaxation time of chains from their relaxation after a strong stretch.

The protocol of thesis §5.4.1 ("Determination of Longest Relaxation Time"): the
solution is stretched in planar elongation at a rate well above the coil–stretch
transition until the chains are nearly fully extended; the rate is then set to zero
(in the box state, between chunks: the lattice stops deforming and SLLOD reduces to
Newton's equations), and the squared end-to-end distance relaxes as

    ⟨R_e²⟩(t) = L_0² e^{−t/λ_0} + L_e²                       (thesis eq. 5.15),

fitted by jaxdpd.analysis.fits.fit_end_to_end_relaxation.  For dumbbells R_e is
the spring vector.  Run replicas (jaxdpd.run.ensemble.replicate with their own seeds; the
thesis averaged three runs): the curve is their mean, each point gets its standard
error over replicas, and the fitted parameters get jackknife errors over replicas
(the fit repeated on the mean of all replicas but one; Efron & Stein, Ann. Stat. 9,
586 (1981); from 3 replicas), which are honest although the points are correlated
in time.  With one
run the fit's errors come from the scatter of the points, which are correlated in
time, so they are too small.
"""

from dataclasses import dataclass

import numpy as np

from jaxdpd.analysis.fits import FitResult, fit_end_to_end_relaxation, jackknife
from jaxdpd.geometry import flows
from jaxdpd.run import driver, ensemble


@dataclass(frozen=True)
class Relaxation:
    """The relaxation curve after the flow stopped, and its fit.

    Attributes:
        times: (T,) times since the flow stopped (the end of each step).
        end_to_end_sq: (T,) ⟨R_e²⟩ over the chains (and replicas), units r_c².
        error: (T,) its standard error over replicas, or None for one run.
        stretched: ⟨R_e²⟩ in the last step of the stretch.
        fit: eq. 5.15 fitted to the points at times ≥ `fit_after`: "amplitude"
            (L_0²), "relaxation_time" (λ_0), "plateau" (L_e²); with replicas its
            errors and covariance are the jackknife ones over replicas.
        per_replica: (B, T) the curve of each replica, or None for one run.
        state: the final state (or batch).
    """

    times: np.ndarray
    end_to_end_sq: np.ndarray
    error: np.ndarray | None
    stretched: float
    fit: FitResult
    state: object
    per_replica: np.ndarray | None = None


def end_to_end_series_name(simulation, species: str) -> str:
    """The conformation series of ⟨R_e²⟩ of `species`' chains (the spring length for
    dumbbells), checking that the scene records it.

    Raises:
        ValueError: naming the scene field that is missing.
    """
    scene = simulation.scene
    blocks = {block.species: block for block in simulation.blocks}
    if species not in blocks:
        raise ValueError(
            f"species = {species!r}: not a chained species; chains are {sorted(blocks)}"
        )
    if "conformation" not in scene.output.observables:
        raise ValueError("output.observables: add 'conformation' to record ⟨R_e²⟩")
    if scene.flow is None or scene.flow.kind != "planar_elongation":
        raise ValueError(
            "flow: the relaxation protocol stretches chains in a [flow] of kind 'planar_elongation'"
        )
    quantity = "end_to_end_sq" if blocks[species].beads > 2 else "bond_length_sq"
    return f"{species}/{quantity}"


def stretch_and_relax(
    simulation,
    state,
    species: str,
    stretch_steps: int,
    relax_steps: int,
    chunk: int,
    stretch_rate: float | None = None,
    fit_after: float = 0.0,
) -> Relaxation:
    """Stretch, stop the flow, record ⟨R_e²⟩(t) and fit eq. 5.15 (module docstring).

    Args:
        simulation: a built planar-elongation scene recording "conformation".
        state: a state, or a batch of replicas (jaxdpd.run.ensemble), to start from.
        species: the chained species to follow.
        stretch_steps: steps at the stretching rate.
        relax_steps: steps at rate zero, all recorded.
        chunk: steps per jitted chunk.
        stretch_rate: ε̇ of the stretch; None keeps the state's rate.
        fit_after: fit only points this long after the flow stopped (let faster
            modes relax first).
    Returns:
        Relaxation.
    """
    name = end_to_end_series_name(simulation, species)
    kind = simulation.scene.flow.kind
    if stretch_rate is not None:
        state = flows.set_flow_rate(state, kind, stretch_rate)
    stretched = []
    state = driver.run(
        simulation,
        state,
        stretch_steps,
        chunk,
        on_chunk=lambda result: stretched.append(result.series[name]),
    )
    state = flows.set_flow_rate(state, kind, 0.0)
    parts = []
    state = driver.run(
        simulation, state, relax_steps, chunk, on_chunk=lambda r: parts.append(r.series[name])
    )
    curves = np.concatenate(parts, axis=-1).astype(np.float64)
    last = np.concatenate(stretched, axis=-1)[..., -1]
    times = simulation.scene.integrator.dt * np.arange(1, relax_steps + 1)
    kept = times >= fit_after
    if not ensemble.is_batch(state) or curves.shape[0] == 1:
        curve = curves.reshape(-1)
        fit = fit_end_to_end_relaxation(times[kept], curve[kept])
        return Relaxation(times, curve, None, float(np.mean(last)), fit, state)
    curve = curves.mean(axis=0)
    error = curves.std(axis=0, ddof=1) / np.sqrt(len(curves))
    fit = fit_end_to_end_relaxation(times[kept], curve[kept], error[kept])
    if len(curves) >= 3:
        fit = replica_jackknife(fit, times[kept], curves[:, kept])
    return Relaxation(times, curve, error, float(np.mean(last)), fit, state, curves)


def replica_jackknife(fit: FitResult, times, curves) -> FitResult:
    """`fit` with the jackknife covariance over replicas (fits.jackknife): the fit
    repeated on the mean of all replicas but one.  Honest for points correlated in
    time, since the replicas are independent.

    Args:
        fit: the fit of the mean curve.
        times: (T,) the fitted times.
        curves: (B, T) each replica's curve at those times; the fits are weighted by
            the standard errors over the replicas kept, as `fit` is over all; B ≥ 3.
    Returns:
        `fit` with the jackknife errors and covariance.
    """

    def refit(others):
        # The weights are estimated from the same replicas, so they are left out too.
        error = others.std(axis=0, ddof=1) / np.sqrt(len(others))
        return fit_end_to_end_relaxation(times, others.mean(axis=0), error)

    return jackknife(fit, refit, curves)
