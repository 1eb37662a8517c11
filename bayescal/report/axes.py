"""Axis helpers of the report pages: readable plain-number ticks on log
axes (several over a narrow band), the PSD's unit (counts when the metadata were ``flat``
placeholders) and the sampler's parameters in the units users read
(degrees, seconds, percent of the metadata gain).
"""
from __future__ import annotations

import numpy as np

#: Tick mantissas on a log axis, by the number of decades spanned.
_SUBS = ((1.2, tuple(range(1, 10))), (2.5, (1.0, 2.0, 5.0)))


#: Below this span (decades) a log axis gets evenly spaced ticks.
NARROW_DECADES = 0.7
#: Most decades labelled on a wide log axis (a stride of decades beyond).
WIDE_TICKS = 8


def log_ticks(ax, lo=None, hi=None, axis="x"):
    """Label a log axis (frequency, PSD, ratio) in plain numbers so that a
    narrow range shows several values: evenly spaced round values under a
    factor 5, 1-9 x 10^n within about a decade, 1, 2, 5 x 10^n within 2.5
    decades, the powers of ten (at most :data:`WIDE_TICKS`) beyond
    (matplotlib's default labels only the powers of ten, which leaves two or
    fewer labels on a band such as 0.125-0.33 Hz, and writes them as
    mathtext). Labels are ``{:g}`` of the value (``0.05``, ``1e-14``); no
    minor ticks (each tick is an object to draw). ``lo``/``hi`` default to
    the axis's current limits."""
    from matplotlib.ticker import FuncFormatter, LogLocator, MaxNLocator, NullLocator

    which = ax.xaxis if axis == "x" else ax.yaxis
    if lo is None or hi is None:
        lo, hi = ax.get_xlim() if axis == "x" else ax.get_ylim()
    lo, hi = min(lo, hi), max(lo, hi)
    decades = np.log10(hi / lo) if lo > 0 and hi > lo else 10.0
    subs = next((s for span, s in _SUBS if decades <= span), (1.0,))
    if decades <= NARROW_DECADES:     # under a factor 5: evenly spaced round values
        which.set_major_locator(MaxNLocator(nbins=6, steps=[1, 2, 2.5, 5, 10]))
    else:
        which.set_major_locator(LogLocator(base=10.0, subs=subs,
                                           numticks=40 if len(subs) > 1 else WIDE_TICKS))
    which.set_major_formatter(FuncFormatter(lambda v, _: f"{v:g}"))
    which.set_minor_locator(NullLocator())


def placeholder_ids(meta):
    """Channel ids (both sensors) whose response was a ``flat`` placeholder
    (their spectra are in counts, not in ground units), from a fit's
    :class:`~bayescal.result.meta.Meta`."""
    p = meta.placeholder_response or {}
    return set(p.get("sut", [])) | set(p.get("reference", []))


def psd_label(meta, ids):
    """The PSD axis label for channels ``ids``: (m/s)^2/Hz, counts^2/Hz when
    every channel had ``flat`` placeholder metadata, both when mixed."""
    flat = placeholder_ids(meta) & set(ids)
    if not flat:
        return "PSD ((m/s)²/Hz)"
    if flat >= set(ids):
        return "PSD (counts²/Hz: 'flat' metadata, no response removed)"
    return "PSD ((m/s)²/Hz; counts²/Hz for 'flat' channels)"


def trace_in_user_units(name, values, nominal=None):
    """A sampler coordinate's trace in the units of the rest of the report:
    ``(values, label)``. Tangent-plane orientation coordinates become the
    angle (deg) from the chain's start direction, azimuths degrees, the
    pendulum's coefficients period (s) and damping/period (1/s), log gain percent off the metadata gain (or the gain when
    no metadata gain is known); anything else is returned as it is."""
    kind = name.split(":")[-1]
    values = np.asarray(values, float)
    if kind in ("orient_a", "orient_b"):
        return np.degrees(np.arctan(values)), "deg from start axis"
    if kind == "azimuth_rad":
        return np.degrees(values), "azimuth (deg)"
    nom = nominal or {}
    if kind == "c0_rel" and nom.get("period_s"):
        with np.errstate(invalid="ignore", divide="ignore"):
            return nom["period_s"] / np.sqrt(values), "period (s)"
    if kind == "c1_rel" and nom.get("period_s"):
        return values * nom["damping"] / nom["period_s"], "damping/period (1/s)"
    if kind == "log_gain":
        g = (nominal or {}).get("gain")
        if g:
            return 100.0 * (np.exp(values) / g - 1.0), "gain, % off metadata"
        return np.exp(values), "gain"
    return values, None


#: Plain words for the sampler's coordinates (the keys of result.json's
#: ``convergence.per_parameter``, after the channel).
PARAMETER_WORDS = {"orient_a": "axis direction, 1st offset", "orient_b": "axis direction, 2nd offset",
                   "azimuth_rad": "azimuth", "c0_rel": "period", "c1_rel": "damping/period",
                   "log_gain": "gain", "damping": "damping"}


def parameter_label(name):
    """A sampler coordinate ``"NET.STA.LOC.CHA:kind"`` in words for a page:
    the channel code and what the coordinate is (e.g. ``"BH1 gain"``);
    a name it does not know is returned as it is."""
    cid, _, kind = name.rpartition(":")
    words = PARAMETER_WORDS.get(kind)
    if words is None:
        return name
    return f"{cid.split('.')[-1]} {words}".strip()
