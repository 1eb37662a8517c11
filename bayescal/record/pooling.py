"""The record's noise inflation: a floor per band under every window's.

Each fit measures, per band, its noise inflation ``c_b``
(:mod:`bayescal.core.model.inflation`): the scatter of its per-segment
residuals over what independent bins would give (window leakage, segment
overlap and non-stationary noise make it larger than 1). A ten-minute
window holds about a dozen segments, so its ``c_b`` scatters from window
to window by chance, and a window whose ``c_b`` reads low is given an
interval narrower than its information allows (below the per-bin Fisher
bound of its spectra); one reading high is given the widening its own
noise asks for.

The windows of one record share their sensors and their noise process:
the median of the windows' ``c_b`` is the record's typical inflation, and
it is a floor for each window's. The windows are first fitted as they
are; a window whose ``c_b`` falls below the floor in some band is fitted
again with it (``inflation_floor``, :func:`bayescal.core.fit.run.fit_spectra`),
the others keep their first fit (a floor that does not bind changes
nothing). A floor, not a common value: a window whose noise scatters more
than the record's keeps its own, wider, inflation.

Measured on COWI's 102 ten-minute windows and on simulated records:
docs/windows.md, docs/validation/hard_posteriors.md.
"""
from __future__ import annotations

import numpy as np

#: Fewest fitted windows from which the record's floor is taken.
MIN_POOLED = 3


def record_floor(inflations):
    """The record's floor per band: the median over windows of their noise
    inflations ``inflations`` (a list of (B,) arrays, the fitted windows');
    None when fewer than :data:`MIN_POOLED` windows share one band layout
    (the most common length ``B``: a window with another layout is not
    counted)."""
    arrays = [np.asarray(c, float).ravel() for c in inflations if c is not None]
    if not arrays:
        return None
    sizes = [a.size for a in arrays]
    common = max(set(sizes), key=sizes.count)
    same = [a for a in arrays if a.size == common]
    if len(same) < MIN_POOLED:
        return None
    return np.median(np.stack(same), axis=0)


def below_floor(inflation, floor):
    """True when a window's inflation (B,) falls below ``floor`` (B,) in
    some band (the window is then fitted again with the floor)."""
    if inflation is None or floor is None:
        return False
    c = np.asarray(inflation, float).ravel()
    return c.size == floor.size and bool(np.any(c < floor))


def floor_windows(windows, refit):
    """``windows`` (:class:`~bayescal.record.windows.Window`, in order) with
    those whose inflation falls below the record's floor replaced by
    ``refit(k, floor)``; returns ``(windows, floor)`` (floor None: too few
    windows to pool, nothing refitted)."""
    floor = record_floor([w.inflation for w in windows if w.fitted])
    out = list(windows)
    for k, w in enumerate(out):
        if w.fitted and below_floor(w.inflation, floor):
            out[k] = refit(k, floor)
    return out, floor
