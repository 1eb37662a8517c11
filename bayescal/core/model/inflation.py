"""The noise-inflation factor ``c_b`` of a plug-in noise model, shrunk
toward its value pooled over bands.

Every likelihood of bayescal measures, per band b, the ratio ``raw_b`` of
the scatter of per-segment (or per-block) residuals to what the
independent-bin formula expects (window leakage, segment overlap and
non-stationary noise make it larger than 1). One band's ratio rests on few
segments, so it is shrunk toward the mean over bands, with weight
``INFLATION_SHRINK`` (in segment x entry counts) against the band's own
``weight``:

    c_b = (w_b raw_b + S pooled) / (w_b + S),   pooled = mean_b raw_b,

and floored at ``1e-3 pooled``.

A fit may also be given a floor per band (``Model.inflation_floor``;
:func:`floor_inflation`): the windows of one record share their noise
process, and a window's ratio, measured on few segments, is not taken to
be below the record's typical one (:mod:`bayescal.record.pooling`).
"""
from __future__ import annotations

import numpy as np

#: Shrinkage weight (in segment x entry counts) of a band's inflation factor
#: toward the value pooled over bands.
INFLATION_SHRINK = 50.0


def shrunk_inflation(raw, weight, pooled_floor=-np.inf, floor=None):
    """Per-band inflation ``c_b`` (B,) from the measured ratios ``raw`` (B,)
    and their weights ``weight`` (scalar or (B,), segment x entry counts).

    Parameters
    ----------
    raw : (B,) measured ratio of residual scatter to its independent-bin value.
    weight : scalar or (B,) how many segment entries each ratio rests on.
    pooled_floor : lower bound on the pooled value in the floor
        ``1e-3 * max(pooled, pooled_floor)`` (a model whose residuals can
        vanish, a noise-free simulation, sets it above 0).
    floor : None or (B,) a lower bound on each band's factor (the record's
        pooled inflation, :mod:`bayescal.record.pooling`).

    Returns
    -------
    (B,) the shrunk, floored inflation factors.
    """
    pooled = raw.mean()
    c = (weight * raw + INFLATION_SHRINK * pooled) / (weight + INFLATION_SHRINK)
    c = np.maximum(c, 1e-3 * max(pooled, pooled_floor))
    return c if floor is None else floor_inflation(c, floor)


def floor_inflation(c, floor):
    """``max(c, floor)`` per band: inflations ``c`` (B,) held at or above
    ``floor`` (B,); a floor of another number of bands is refused (FitError)."""
    floor = np.asarray(floor, float)
    if floor.shape != np.shape(c):
        from ...errors import FitError
        raise FitError(f"an inflation floor of {floor.size} bands given to a fit of {np.size(c)}")
    return np.maximum(c, floor)


def overlapping_segments(segment_starts, nperseg):
    """Indices ``k`` of the segments that overlap the next one (their starts
    closer than ``nperseg`` samples): the pairs ``(k, k + 1)`` whose
    residuals are correlated."""
    return np.flatnonzero(np.diff(segment_starts) < nperseg)


def lag_one_scatter(quadratic, residuals, adjacent):
    """Per-band scatter of per-segment residuals with its lag-one term,
    ``q0 + 2 q1``: ``q0 = quadratic(r, r)`` summed over the segments,
    ``q1 = quadratic(r[k + 1], r[k])`` summed over the overlapping pairs
    ``adjacent`` (:func:`overlapping_segments`; empty for independent
    segments), so that the ratio to its independent-bin value is the raw
    inflation :func:`shrunk_inflation` shrinks.

    Parameters
    ----------
    quadratic : callable ``(x, y) -> (B,)``, the quadratic form of two stacks
        of per-segment residuals (K', B, ...) summed over the segments.
    residuals : (K, B, ...) per-segment residuals.
    adjacent : int array, the first segment of each overlapping pair.

    Returns
    -------
    (B,) ``q0 + 2 q1``.
    """
    q0 = quadratic(residuals, residuals)
    q1 = quadratic(residuals[adjacent + 1], residuals[adjacent])
    return q0 + 2.0 * q1
