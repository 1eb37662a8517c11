"""The record's noise inflation: a floor per band under every window's.

Each fit measures, per band, its noise inflation ``c_b``
(:mod:`bayescal.core.model.inflation`): the scatter of its per-segment
residuals over what independent bins would give (window leakage, segment
overlap and non-stationary noise make it larger than 1). A ten-minute
window holds about a dozen segments, so its ``c_b`` scatters from window
to window, partly by chance (so few segments), partly because the noise is
not stationary; a window whose ``c_b`` reads low is given an interval
that can fall below the per-bin Fisher bound of its spectra, one reading
high the widening its own noise asks for.

The windows of one record share their sensors and their noise process:
the median of the windows' ``c_b`` (over those of the most common bands)
is the record's typical inflation, and it is a floor for each window's:
a window is not taken to be quieter than the record's typical one, while
one noisier keeps its own inflation. The windows are first fitted as they
are; a window whose ``c_b`` falls below the floor in some band is fitted
again with it (``inflation_floor``, :func:`bayescal.core.fit.run.fit_spectra`),
the others keep their first fit (a floor that does not bind changes
nothing). A floor, not a common value: a window whose noise scatters more
than the record's keeps its own, wider, inflation.

Measured on COWI's 102 ten-minute windows and on simulated records:
docs/windows.md, docs/validation/hard_posteriors.md.
"""
from __future__ import annotations

from dataclasses import replace

import numpy as np

#: Fewest fitted windows of one band layout from which the record's floor is taken.
MIN_POOLED = 3


def record_floor(windows):
    """The record's floor per band: the median of the noise inflations of
    the fitted ``windows`` (:class:`~bayescal.record.windows.Window`) over
    those whose bands (``band_edges_hz``) are the most common layout's;
    returns ``(floor (B,), edges)``, or ``(None, None)`` when fewer than
    :data:`MIN_POOLED` windows share a layout (a window with other bands is
    not floored: a floor is per band, so only windows of the same bands share one)."""
    layouts = {}
    for w in windows:
        if w.fitted and w.inflation is not None and w.band_edges_hz is not None \
                and len(w.band_edges_hz) == np.size(w.inflation) + 1:
            layouts.setdefault(w.band_edges_hz, []).append(np.asarray(w.inflation, float))
    if not layouts:
        return None, None
    edges, same = max(layouts.items(), key=lambda kv: (len(kv[1]), kv[0]))
    if len(same) < MIN_POOLED:
        return None, None
    return np.median(np.stack(same), axis=0), edges


def below_floor(window, floor, edges):
    """True when ``window`` is fitted, has the bands ``edges`` and its
    inflation falls below ``floor`` (B,) in some band (it is then fitted
    again with the floor)."""
    if floor is None or not window.fitted or window.band_edges_hz != edges \
            or window.inflation is None:
        return False
    return bool(np.any(np.asarray(window.inflation, float) < floor))


def floor_windows(windows, refit):
    """``windows`` (:class:`~bayescal.record.windows.Window`, in order) with
    those whose inflation falls below the record's floor replaced by
    ``refit(k, floor)`` (kept only when it fits: a refit the fit refuses
    leaves the first fit), and every window of the floor's bands given the
    floor (``Window.floor``); nothing changes when too few windows share
    one band layout (:func:`record_floor`)."""
    floor, edges = record_floor(windows)
    out = list(windows)
    for k, w in enumerate(out):
        if floor is None or w.band_edges_hz != edges or not w.fitted:
            continue
        new = refit(k, floor) if below_floor(w, floor, edges) else None
        out[k] = new if new is not None and new.fitted else replace(w, floor=floor)
    return out
