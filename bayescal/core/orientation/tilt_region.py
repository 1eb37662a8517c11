"""Credible statements about a near-vertical channel's tilt, from the 2-D
credible region of its lean components.

A tilt is a magnitude, ``sqrt(north^2 + east^2)`` of the lean toward north
and toward east, so an equal-tailed interval of its samples never holds 0:
for a channel that is truly vertical it misses every time, however good the
posterior. The two lean components are well defined and close to Gaussian
when the tilt is small (:func:`bayescal.core.orientation.geometry.tilt_components`), so
the statement is made in their plane:

* the credible region at level ``p`` is the ellipse of the samples' mean and
  covariance, ``(x - m)^T S^-1 (x - m) <= q``, ``q`` the ``p`` quantile of the
  samples' own squared Mahalanobis distances (so it holds a fraction ``p``
  of the samples whatever their tails);
* the tilt's interval is the range of tilts over that region: ``[0, X]``
  ("tilt < X deg") when the region holds the vertical (lean 0, 0), else
  ``[lo, hi]``, the nearest and farthest points of the ellipse.

The truth lies in the tilt interval whenever its lean lies in the region, so
the interval covers at least as often as the region does: at tilt 0 exactly
as often, farther out more often (for a Gaussian region far from 0, about
98.6 % at p = 0.95, as a 2-D region's radial extent is wider than a 1-D
interval). The dip of the channel follows from the tilt: ``-90 + tilt`` for
an upward vertical, ``90 - tilt`` for a downward one.

Plain numpy; degrees throughout.
"""
from __future__ import annotations

import numpy as np

from .geometry import tilt_components

__all__ = ["lean_region", "tilt_intervals", "REGION_NOTE"]

#: Points on the region's boundary searched for the nearest and farthest tilt.
N_BOUNDARY = 4096
#: How the intervals of a near-vertical channel's tilt and dip are made.
REGION_NOTE = ("tilt and dip intervals: the range of tilts in the elliptical credible region "
               "of the lean north/east components (lower bound 0 when the region holds the "
               "vertical)")


def _tilt_of_lean(north_deg, east_deg):
    """Tilt (degrees) of an axis whose upward direction leans ``north_deg``
    and ``east_deg`` (the angles of :func:`tilt_components`)."""
    h = np.hypot(np.sin(np.radians(north_deg)), np.sin(np.radians(east_deg)))
    return np.degrees(np.arcsin(np.clip(h, 0.0, 1.0)))


def lean_region(north, east, level=0.95):
    """The ``level`` credible region of lean samples ``north``, ``east``
    (degrees, (N,) each) and the range of tilts it holds.

    Returns a dict: ``mean`` (2,), ``cov`` (2, 2), ``q`` (threshold of the
    squared Mahalanobis distance), ``holds_zero`` (the region holds lean 0,
    0: a vertical axis is credible) and ``tilt`` = [lo, hi] in degrees
    (lo = 0 when it holds zero).
    """
    x = np.stack([np.asarray(north, float), np.asarray(east, float)], axis=1)
    m = x.mean(axis=0)
    S = np.cov(x, rowvar=False)
    S = S + np.eye(2) * 1e-12 * max(np.trace(S), 1e-300)   # a degenerate chain stays finite
    Si = np.linalg.inv(S)
    d = x - m
    q = float(np.quantile(np.einsum("ni,ij,nj->n", d, Si, d), level))
    holds_zero = bool(m @ Si @ m <= q)
    L = np.linalg.cholesky(S)
    theta = np.linspace(0.0, 2 * np.pi, N_BOUNDARY, endpoint=False)
    edge = m[None, :] + np.sqrt(q) * np.stack([np.cos(theta), np.sin(theta)], 1) @ L.T
    tilts = _tilt_of_lean(edge[:, 0], edge[:, 1])
    hi = float(max(tilts.max(), _tilt_of_lean(*m)))
    lo = 0.0 if holds_zero else float(tilts.min())
    return {"mean": m, "cov": S, "q": q, "holds_zero": holds_zero, "tilt": [lo, hi]}


def tilt_intervals(vectors, levels):
    """Tilt and dip intervals of a near-vertical channel from its axis
    samples ``vectors`` (N, 3) (NED unit vectors).

    ``levels``: name -> credible level, e.g. ``{"ci68": 0.68, "ci95": 0.95}``.
    Returns ``(tilt, dip, holds)``: name -> [lo, hi] degrees for the tilt
    and for the SEED dip (which follows it), and name -> whether that
    region holds the vertical.
    """
    v = np.asarray(vectors, float)
    north, east = tilt_components(v)
    upward = float(np.median(v[:, 2])) <= 0
    tilt, dip, holds = {}, {}, {}
    for name, level in levels.items():
        r = lean_region(north, east, level)
        lo, hi = r["tilt"]
        tilt[name] = [lo, hi]
        dip[name] = [-90.0 + lo, -90.0 + hi] if upward else [90.0 - hi, 90.0 - lo]
        holds[name] = r["holds_zero"]
    return tilt, dip, holds
