"""The SUT's self-noise held fixed in its counts, not in ground units.

The plug-in noise model of a fit (``Sigma_b`` of
:mod:`bayescal.core.model.likelihood`, ``V_b`` of :mod:`bayescal.core.model.eiv`) is
estimated once, at the least-squares point ``a0``. The SUT's self-noise is a
property of the sensor in its counts: deconvolved by a response ``H(a)`` it
scales with ``|rho(a)| = |H_nom / H(a)|``. Held fixed in ground units, as the
residual's noise once was, a larger gain shrinks the residual against an
unchanged noise and is preferred: the gains came out high by about
``dim * sd^2`` in relative terms (``dim`` the residual's real dimension per
channel, ``sd`` the gain's relative standard deviation), +0.6 sd at coherence
0.9 (docs/validation/errors_in_variables.md). Comparing row ``i`` of the residual with
the plug-in noise after multiplying it by ``|rho_b,i(a0)| / |rho_b,i(a)|``
(the row in the counts of the plug-in point) removes that.
"""
from __future__ import annotations

import numpy as np


def band_node_weights(onehot, interp):
    """(Q, B) weights giving each band's mean of a node function
    interpolated to the bins: ``onehot`` (F, B), ``interp`` (F, Q)."""
    return (onehot.T @ interp).T / onehot.sum(axis=0)


def noise_scale(ratio, weights, rows):
    """(W, n_u, B) band rms of the deconvolution factor ``|ratio|`` (W, n_u,
    Q) for the channels ``rows`` whose response is free (1 elsewhere)."""
    out = np.ones((ratio.shape[0], ratio.shape[1], weights.shape[1]))
    for j in rows:
        out[:, j] = np.sqrt(np.abs(ratio[:, j]) ** 2 @ weights)
    return out


def rescale_rows(r, scale0, ratio, weights, rows):
    """``r`` (W, ..., B, n_u, n_r) with row ``i`` of band ``b`` times
    ``scale0[i, b] / noise_scale(ratio)[w, i, b]``: the residual in the
    counts of the plug-in point. ``scale0`` None (no plug-in noise yet) or
    no free row leaves ``r`` as it is."""
    if scale0 is None or not len(rows):
        return r
    f = (scale0[None] / noise_scale(ratio, weights, rows)).transpose(0, 2, 1)   # (W, B, nu)
    return r * f.reshape((f.shape[0],) + (1,) * (r.ndim - 4) + f.shape[1:] + (1,))
