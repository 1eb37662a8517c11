"""Self-noise report (:class:`bayescal.io.noise.NoiseResult`): one A4 page per
component (Z, N, E), in ``noise.pdf`` and as ``noise_<component>.png``,
drawn from the output folder alone: ``noise.json`` and the estimates at
full precision in ``noise_curves.npz`` (:func:`save_curves`,
:func:`read_result`).

Each page shows every sensor's self-noise estimate with its interval band,
each channel's recorded PSD (ambient signal plus self-noise, dotted), and
Peterson's NLNM and NHNM (ObsPy's noise-model data, :func:`peterson_models`),
in dB re 1 (m/s^2)^2/Hz against period; below, a table of the estimates at a few
periods. Where an estimate is below resolution (its interval reaches zero
power) no point is drawn: a downward caret sits on the upper bound and the
band runs from the bottom of the axes to it (an upper bound only).
Drawn with matplotlib's object API (no display, no pyplot state).
"""
from __future__ import annotations

import functools
import importlib.util
import os
import textwrap

import numpy as np

from ..core.selfnoise import below_resolution, db
from ..atomic import record_written  # noqa: E402
from .axes import log_ticks
from .layout import A4, LINESTYLES, MARKERS, legend_beside, style, write_pages

COLOURS = ("C0", "C3", "C2", "C1", "C4", "C5", "C6", "C7")
#: Periods (s) of the table under the figure (nearest band; outside the band left out).
TABLE_PERIODS = (0.2, 0.5, 1.0, 2.0, 5.0, 10.0, 30.0, 100.0)
PNG_DPI = 90
#: Marker of an upper bound (matplotlib's CARETDOWNBASE: a downward caret
#: whose base sits on the bound).
UPPER_BOUND_MARKER = 11


def _cell(value, lo, hi):
    def f(x):
        return "-inf" if x == -np.inf else ("nan" if not np.isfinite(x) else f"{x:.1f}")
    if lo == -np.inf and np.isfinite(hi):
        return f"< {hi:.1f} below resolution"
    head = "  (<= 0)" if not np.isfinite(value) else f"{value:7.1f}"
    return f"{head} [{f(lo)}, {f(hi)}]"


def _table_lines(comp):
    e = comp.estimate
    ci = e.ci_db()
    psd = e.psd_db()
    lines = [f"{'period s':>9}  " + "  ".join(f"{cid:>28}" for cid in comp.ids)]
    pmin, pmax = e.period_s.min(), e.period_s.max()
    for p in TABLE_PERIODS:
        if not pmin / 1.2 <= p <= pmax * 1.2:
            continue
        b = int(np.argmin(np.abs(np.log(e.period_s / p))))
        cells = [_cell(psd[i, b], ci[0, i, b], ci[1, i, b]) for i in range(len(comp.ids))]
        lines.append(f"{e.period_s[b]:9.3g}  " + "  ".join(f"{c:>28}" for c in cells))
    return lines


def short_ids(ids):
    """Channel ids without the leading NET.STA.LOC parts they all share
    (``["II.XPFO.00.BHZ", "II.XPFO.10.BHZ"]`` -> ``["00.BHZ", "10.BHZ"]``;
    one id -> its channel code), for legends beside a page that names them."""
    parts = [str(c).split(".") for c in ids]
    n = min(len(p) for p in parts) if parts else 0
    keep = 1
    while keep < n and len({tuple(p[-keep:]) for p in parts}) < len(parts):
        keep += 1
    return [".".join(p[-keep:]) for p in parts]


@functools.lru_cache(maxsize=1)
def peterson_models():
    """Peterson's (1993) NLNM and NHNM as ObsPy ships them (the data file
    its ``obspy.signal.spectral_estimation.get_nlnm`` and ``get_nhnm``
    read), loaded with numpy from ObsPy's package folder without importing
    ``obspy.signal``, whose import brings scipy.signal and scipy.stats.

    Returns
    -------
    ((period_s, nlnm_db), (period_s, nhnm_db)) : arrays, periods in s, PSDs
        in dB re 1 (m/s^2)^2/Hz.
    """
    spec = importlib.util.find_spec("obspy")     # locates ObsPy without importing it
    path = os.path.join(os.path.dirname(spec.origin), "signal", "data", "noise_models.npz")
    with np.load(path) as data:
        period, low, high = (data[k] for k in ("model_periods", "low_noise", "high_noise"))
    for a in (period, low, high):
        a.flags.writeable = False                 # shared by every caller (cached)
    return (period, low), (period, high)


def draw_estimates(ax, e, ids):
    """Draw self-noise estimates on ``ax``: each channel's estimate with its
    interval band and its recorded PSD (dotted), and Peterson's NLNM and
    NHNM, in dB re 1 (m/s^2)^2/Hz against period. ``e`` a
    :class:`bayescal.core.selfnoise.sleeman.SelfNoise` (or anything with its
    ``period_s``, ``psd``, ``lo``, ``hi``, ``signal``, ``level``), ``ids``
    its channel labels. Also used by the pair fit's self-noise page.

    Where an interval reaches zero power (below resolution) the estimate is
    not drawn as a point: a downward caret (:data:`UPPER_BOUND_MARKER`) marks
    the upper bound."""
    order = np.argsort(e.period_s)
    per = e.period_s[order]
    (pl, nl), (ph, nh) = peterson_models()
    ax.semilogx(pl, nl, color="0.25", lw=1.6, label="NLNM")
    ax.semilogx(ph, nh, color="0.6", lw=1.6, label="NHNM")
    lo_db, hi_db = db(e.lo), db(e.hi)
    bottom, top = _db_range(per, lo_db, db(e.psd), db(e.signal), (pl, nl), (ph, nh))
    for i, cid in enumerate(short_ids(ids)):
        c, ls = COLOURS[i % len(COLOURS)], LINESTYLES[i % len(LINESTYLES)]
        ax.semilogx(per, db(e.signal[i, order]), color=c, lw=0.7, ls=":", label=f"{cid} recorded")
        lo = np.where(np.isfinite(lo_db[i, order]), lo_db[i, order], bottom)
        hi = np.where(np.isfinite(hi_db[i, order]), hi_db[i, order], top)
        ax.fill_between(per, lo, hi, color=c, alpha=0.22, lw=0)
        below = below_resolution(np.asarray(e.lo)[i, order])
        shown = np.where(below, np.nan, db(e.psd[i, order]))
        ax.semilogx(per, shown, color=c, ls=ls, lw=1.3, marker=MARKERS[i % len(MARKERS)], ms=2.5,
                    label=f"{cid} self-noise, {round(100 * e.level)} % band"
                    if np.isfinite(shown).any() else "_not drawn")   # below resolution throughout
        bound = below & np.isfinite(hi_db[i, order]) & (hi_db[i, order] > bottom)
        if bound.any():
            ax.semilogx(per[bound], hi_db[i, order][bound], ls="none",
                        marker=UPPER_BOUND_MARKER, ms=6, color=c,
                        label=f"{cid} upper bound (below resolution)")
    ax.set_xlim(per.min() * 0.9, per.max() * 1.1)
    ax.set_ylim(bottom, top)
    log_ticks(ax)
    ax.set_xlabel("period (s)")
    ax.set_ylabel("PSD, dB re 1 (m/s²)²/Hz")
    ax.grid(True, which="major", lw=0.4)
    # beside the axes, never over a curve
    legend_beside(ax, fontsize=6.5)


#: How far (dB) below the lowest of the NLNM and the estimates the axes
#: reach: a band reaching lower runs to the axes' bottom (its lower end is
#: then not resolved, as for a band reaching zero power).
BAND_DEPTH_DB = 25.0


def _db_range(per, lo_db, psd_db, signal_db, nlnm, nhnm):
    """(bottom, top) of the PSD axis in dB: the estimates, the recordings
    and Peterson's NLNM and NHNM over the periods ``per`` shown; interval
    bands reach down to :data:`BAND_DEPTH_DB` below the lowest of those."""
    shown = [np.interp(per, *m)[(per >= m[0].min()) & (per <= m[0].max())] for m in (nlnm, nhnm)]
    values = np.concatenate([np.ravel(psd_db), np.ravel(signal_db), *shown])
    values = values[np.isfinite(values)]
    lowest, highest = (values.min(), values.max()) if values.size else (-200.0, -90.0)
    finite_lo = lo_db[np.isfinite(lo_db)]
    bottom = max(min(finite_lo.min() if finite_lo.size else lowest, lowest) - 5,
                 lowest - BAND_DEPTH_DB)
    return bottom, highest + 10


def figure_component(comp, result=None):
    """The A4 page (a matplotlib ``Figure``) of one
    :class:`bayescal.io.noise.ComponentNoise`."""
    from matplotlib.figure import Figure

    fig = Figure(figsize=A4)
    ax = fig.add_axes([0.1, 0.42, 0.6, 0.48])
    draw_estimates(ax, comp.estimate, comp.ids)
    how = "median over pairs of the other sensors" if len(comp.ids) > 3 else "three sensors"
    fig.text(0.04, 0.975, f"Self-noise, component {comp.component}", fontsize=12,
             fontweight="bold", va="top")
    sub = [f"Sleeman et al. (2006), {how}; {comp.n_segments} Hann segments of {comp.nperseg} "
           f"samples ({100 * comp.fraction_used:.0f} % of the record used); band "
           f"{comp.band_hz[0]:.4g}-{comp.band_hz[1]:.4g} Hz."]
    if result is not None:
        m = result.meta
        allowance = m.get("axis_mismatch_rad")
        sub.append(f"Window {result.starttime} - {result.endtime}, {result.fs:g} Hz. "
                   f"Interval: {m.get('method')} bootstrap, {m.get('n_boot')} replicates"
                   + ("" if allowance is None else
                      f", axis-mismatch allowance {allowance:g} rad rms") + ".")
    fig.text(0.04, 0.945, "\n".join(textwrap.fill(t, 115) for t in sub), fontsize=7.5,
             va="top")
    lines = textwrap.wrap("Self-noise, dB re 1 (m/s^2)^2/Hz, [90 % interval] at the band "
                          "nearest each period; '< X below resolution': the interval reaches "
                          "zero power, X is its upper bound.", 110) + [""]
    lines += _table_lines(comp)
    fig.text(0.04, 0.34, "\n".join(lines), family="monospace", fontsize=6.5, va="top")
    return fig


def write_figures(result, folder, dpi=PNG_DPI):
    """``noise.pdf`` (one page per component) and ``noise_<component>.png``
    into ``folder``; returns the paths written."""
    pdf_path = os.path.join(folder, "noise.pdf")
    with style():
        pngs = write_pages(((os.path.join(folder, f"noise_{comp.component}.png"),
                             figure_component(comp, result)) for comp in result.components),
                           pdf_path, dpi=dpi, grey=False)
    return [pdf_path] + pngs


#: The fields of a :class:`bayescal.core.selfnoise.sleeman.SelfNoise` saved per component.
CURVE_FIELDS = ("freqs", "psd", "lo", "hi", "dof", "signal", "pair_range")


def save_curves(result, folder):
    """Write ``noise_curves.npz`` into ``folder``: per component ``c`` the
    channel ids ``<c>_ids``, the fraction of the record used
    ``<c>_fraction_used`` and each estimate field ``<c>_<field>``
    (:data:`CURVE_FIELDS`; PSD in (m/s^2)^2/Hz); returns its path."""
    arrays = {}
    for comp in result.components:
        arrays[f"{comp.component}_ids"] = np.array(comp.ids)
        arrays[f"{comp.component}_fraction_used"] = comp.fraction_used
        arrays.update({f"{comp.component}_{k}": getattr(comp.estimate, k) for k in CURVE_FIELDS})
    path = os.path.join(folder, "noise_curves.npz")
    np.savez(path, **arrays)
    return path


def read_result(folder):
    """The :class:`bayescal.io.noise.NoiseResult` the figures need, from a
    ``bayescal noise`` folder's ``noise.json`` and ``noise_curves.npz``."""
    import json

    from ..core.selfnoise import SelfNoise
    from ..io.noise import ComponentNoise, NoiseResult

    with open(os.path.join(folder, "noise.json")) as fh:
        meta = json.load(fh)["meta"]
    components = []
    with np.load(os.path.join(folder, "noise_curves.npz")) as npz:
        for comp, seg in meta["segments"].items():
            fields = {k: npz[f"{comp}_{k}"] for k in CURVE_FIELDS}
            ids = [str(c) for c in npz[f"{comp}_ids"]]
            est = SelfNoise(level=meta["level"], method=meta["method"], ids=ids, **fields)
            components.append(ComponentNoise(comp, ids, est, seg["nperseg"], seg["n_segments"],
                                             float(npz[f"{comp}_fraction_used"]),
                                             tuple(meta["band_hz"])))
    return NoiseResult(components, meta["fs_hz"], meta["start"], meta["end"], meta["files"],
                       meta=meta)


def write_report_from_folder(folder, paper="a4"):
    """Redraw the figures of a ``bayescal noise`` folder from its files
    (:func:`read_result`, :func:`write_figures`; A4 pages whatever
    ``paper``); returns the paths written."""
    paths = write_figures(read_result(folder), folder)
    record_written(folder, [os.path.basename(p) for p in paths])
    return paths
