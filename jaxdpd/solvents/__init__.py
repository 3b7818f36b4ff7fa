"""Solvent methods: Groot–Warren DPD, Lowe–Andersen, Hoogerbrugge–Koelman, MPCD and
lattice Boltzmann."""
