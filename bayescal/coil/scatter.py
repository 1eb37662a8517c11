"""The variance of a band's residual summed over segments, measured from the
scatter of its per-segment residuals about their mean.

A calibration run's band residual is ``R_b = sum_k r_k`` over K segments
(half-overlapping ones correlated with their neighbour). Its variance is
``Var R_b = K v + 2 n_adj w`` with ``v`` the variance of one segment's
residual, ``w`` the covariance of two overlapping ones and ``n_adj`` the
number of overlapping pairs. The sums ``q0 = sum_k |r_k|^2`` and ``q1 =
sum_adj Re r_{k+1}^* r_k`` estimate it without bias only when the ``r_k`` have
mean zero, that is at the true parameters: at fitted ones the fit has taken
part of each ``R_b`` away, and with ``R_b`` a third of ``q0 + 2 q1`` (about
``3 / K`` of it) the variance comes out low by the fit's share of the band
residuals (about 6 % at 12 segments, 3 parameters and 8 bands).

Here the ``r_k`` are centred first, ``P r`` with ``P = I - 1 1^T / K``, which
no parameter can change; with ``Sigma = v I + w A`` (``A`` the adjacency of
overlapping segments, both directions)

    E q0' = v tr P + w tr(P A),     E q1' = (v tr(P D P) + w tr(P D P A)),

``D = A / 2``; this 2 x 2 system gives ``v`` and ``w`` from ``q0'`` and ``q1'``
and hence ``Var R_b``, unbiased at any parameter value.
"""
from __future__ import annotations

import numpy as np

from ..errors import InputError

#: Fewest segments whose centred scatter separates ``v`` from ``w``: two
#: centred residuals have one degree of freedom (``r_1 - r_2``), which two
#: unknowns cannot share.
MIN_SEGMENTS = 3


def centred_weights(n_segments, adjacent):
    """Coefficients ``(a0, a1)`` with ``E[a0 q0' + a1 q1'] = Var R_b`` for
    centred residuals of ``n_segments`` segments whose pairs ``(k, k + 1)``
    for ``k`` in ``adjacent`` overlap (module docstring).

    Parameters
    ----------
    n_segments : int, K.
    adjacent : int array, first segment of each overlapping pair.

    Returns
    -------
    (2,) array ``(a0, a1)``.

    Raises
    ------
    InputError
        Fewer than :data:`MIN_SEGMENTS` segments (two independent ones
        suffice): the run is too short for its noise model.
    """
    k = int(n_segments)
    adjacent = np.asarray(adjacent, int)
    if k < (MIN_SEGMENTS if adjacent.size else 2):
        raise InputError(f"only {k} segment(s) of the run: its noise model needs at least "
                         f"{MIN_SEGMENTS}; record a longer run")
    if adjacent.size == 0:                        # independent segments: v only
        return np.array([k / (k - 1.0), 0.0])
    adj = np.zeros((k, k))
    adj[adjacent, adjacent + 1] = adj[adjacent + 1, adjacent] = 1.0
    p = np.eye(k) - 1.0 / k
    pdp = p @ (0.5 * adj) @ p
    m = np.array([[np.trace(p), np.trace(p @ adj)],
                  [np.trace(pdp), np.trace(pdp @ adj)]])
    return np.linalg.solve(m.T, np.array([k, adj.sum()]))


def centred_band_variance(quadratic, residuals, adjacent):
    """Per band, the unbiased estimate of ``Var sum_k r_k`` from the
    per-segment residuals centred on their mean (module docstring).

    Parameters
    ----------
    quadratic : callable ``(x, y) -> (B,)``, the real quadratic form of two
        stacks of per-segment residuals (K', B, ...) summed over segments.
    residuals : (K, B, ...) per-segment residuals.
    adjacent : int array, first segment of each overlapping pair
        (:func:`bayescal.core.model.overlapping_segments`).

    Returns
    -------
    (B,) the estimated variance of the band's summed residual.
    """
    adjacent = np.asarray(adjacent, int)
    r = residuals - residuals.mean(axis=0, keepdims=True)
    q0 = quadratic(r, r)
    q1 = quadratic(r[adjacent + 1], r[adjacent])
    a0, a1 = centred_weights(residuals.shape[0], adjacent)
    return a0 * q0 + a1 * q1
