"""The frequency nodes at which a model evaluates its response ratios, and
the weights that interpolate from them to the frequency bins.

A response ratio ``H_nom(f) / H(f; a)`` is smooth in frequency: it is
evaluated at ``NODES_PER_DECADE`` log-spaced nodes per decade and linearly
interpolated (in log frequency) to the bins, so that a likelihood call costs
O(nodes), not O(bins).
"""
from __future__ import annotations

import numpy as np

#: Density of the nodes at which response ratios are evaluated.
NODES_PER_DECADE = 60


def interpolation_nodes(freqs, per_decade=NODES_PER_DECADE):
    """Log-spaced nodes spanning ``freqs`` and the (F, Q) matrix of linear
    interpolation weights (in log frequency) from nodes to bins. With fewer
    bins than nodes, the bins themselves are the nodes (weights = identity)."""
    freqs = np.asarray(freqs, float)
    lo, hi = np.log10(freqs[0]), np.log10(freqs[-1])
    q = max(2, int(np.ceil((hi - lo) * per_decade)) + 1)
    if q >= freqs.size:
        return freqs.copy(), np.eye(freqs.size)
    nodes = np.logspace(lo, hi, q)
    x, xn = np.log10(freqs), np.log10(nodes)
    j = np.clip(np.searchsorted(xn, x, side="right") - 1, 0, q - 2)
    frac = (x - xn[j]) / (xn[j + 1] - xn[j])
    weights = np.zeros((freqs.size, q))
    weights[np.arange(freqs.size), j] = 1.0 - frac
    weights[np.arange(freqs.size), j + 1] = frac
    return nodes, weights
