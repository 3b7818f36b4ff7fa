"""Multiparticle collision dynamics (MPCD) in its stochastic-rotation form (SRD).

Mussawisade, Ripoll, Winkler & Gompper, J. Chem. Phys. 123, 144905 (2005), §II:
    cells       collision cells, random grid shift, per-cell sums
    collision   SRD rotation, the solvent-free Rouse variant, the MBS thermostat,
                the collisional virial
    step        the scene's MPCD step (streaming with monomer sub-steps, collision)
    transport   analytic viscosity (eq. 6) and centre-of-mass dynamics (eqs. 7–12)
"""
