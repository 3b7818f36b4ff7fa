"""Exact ideal (Gaussian random-walk) chains for the polymer-observable tests.

Bond vectors are independent Gaussian vectors with ``<|b|^2> = bond_length_squared``
(each component of variance ``bond_length_squared / 3``); the first bead is placed
uniformly in a box of edge 10 (irrelevant to every intrachain observable).
"""

import numpy as np


def gaussian_chains(seed: int, n_chains: int, n_beads: int, bond_length_squared: float = 1.0):
    """``(n_chains, n_beads, 3)`` float64 positions of independent Gaussian chains."""
    rng = np.random.default_rng(seed)
    bonds = rng.normal(scale=np.sqrt(bond_length_squared / 3), size=(n_chains, n_beads - 1, 3))
    start = rng.uniform(0, 10, size=(n_chains, 1, 3))
    return np.concatenate([start, start + np.cumsum(bonds, axis=1)], axis=1)


def mean_and_error(samples, axis: int = 0):
    """Mean and standard error over independent samples along ``axis``."""
    samples = np.asarray(samples, dtype=np.float64)
    n = samples.shape[axis]
    return samples.mean(axis=axis), samples.std(axis=axis, ddof=1) / np.sqrt(n)
