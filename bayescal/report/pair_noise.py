"""Report page of a pair fit's self-noise: every channel of both sensors
against Peterson's NLNM and NHNM (drawn as ``bayescal noise`` draws them,
:func:`bayescal.report.noise.draw_estimates`), from result.json's
``self_noise`` entry (:mod:`bayescal.core.selfnoise.pair_noise`). A pair that cannot
separate the two sensors' noise gets the reason instead of a figure."""
from __future__ import annotations

import textwrap
from types import SimpleNamespace

import numpy as np

from .noise import draw_estimates


def _as_estimate(channels):
    """The identified channels of ``self_noise["channels"]`` as a
    SelfNoise-like namespace (linear power) and their ids."""
    ids = [cid for cid, e in channels.items() if "psd_db" in e]
    if not ids:
        return None, []

    def lin(x):
        x = np.array([np.nan if v is None else v for v in x], float)
        return 10 ** (x / 10)

    first = channels[ids[0]]
    key = next(k for k in first if k.startswith("ci") and k.endswith("_db"))
    lo = np.array([np.nan_to_num(lin(channels[c][key][0]), nan=0.0) for c in ids])
    # no positive upper bound (the whole interval at or below 0): draw no band
    hi = np.array([np.nan_to_num(lin(channels[c][key][1]), nan=1e-300) for c in ids])
    return SimpleNamespace(period_s=1.0 / np.asarray(first["freq_hz"], float),
                           psd=np.array([lin(channels[c]["psd_db"]) for c in ids]), lo=lo,
                           hi=hi, signal=np.array([lin(channels[c]["recorded_db"]) for c in ids]),
                           level=int(key[2:-3]) / 100), ids


def _rows(est, rows):
    """The estimate namespace restricted to channel rows ``rows``."""
    return SimpleNamespace(period_s=est.period_s, level=est.level,
                           **{k: getattr(est, k)[rows] for k in ("psd", "lo", "hi", "signal")})


#: The basis's formulas in words (result.json keeps the formulas; docs/science.md).
PLAIN = {"diag(S_uu - S_ur T^H) and diag(S_rr - T^+ S_ur) with the fitted transfer T":
         "each channel's power that the other sensor does not explain (what remains when "
         "the fitted transfer between the sensors takes the common ground motion out)",
         "Wishart variance of the band spectra plus the scatter over posterior draws of T":
         "the spectra's own scatter plus the spread over posterior draws of the fitted "
         "transfer",
         "T absorbs": "the fitted transfer absorbs"}


def plain_basis(basis):
    """result.json's ``self_noise.basis`` in words for an instrument engineer."""
    for formula, words in PLAIN.items():
        basis = basis.replace(formula, words)
    return basis


def page_self_noise(ctx):
    """The self-noise page, or None when result.json has no ``self_noise``."""
    from matplotlib.figure import Figure

    from ..criticism.words import self_noise_text

    entry = ctx.summary.get("self_noise")
    if not entry:
        return None
    fig = Figure(figsize=ctx.page)
    fig.text(0.06, 0.965, "Self-noise of both sensors", fontsize=13, fontweight="bold")
    est, ids = _as_estimate(entry["channels"])
    lines = textwrap.wrap(f"How: {plain_basis(entry['basis'])}.", 110)
    if self_noise_text(ctx.summary):
        lines += textwrap.wrap(f"Model: {self_noise_text(ctx.summary)}.", 110)
    lines += textwrap.wrap(f"Units: {entry.get('units', '')}.", 110)
    order = ctx.summary.get("sensor_order", {})
    if order.get("message"):
        lines += textwrap.wrap(f"WARNING: {order['message']}", 110)
    for key in ("caution", "undetermined", "basis"):
        if order.get(key):
            lines += textwrap.wrap(f"Sensor order ({key}): {order[key]}", 110)
    for cid, e in entry["channels"].items():
        if "not_identifiable" in e:
            lines += textwrap.wrap(f"{cid}: {e['not_identifiable']}", 110)
    fig.text(0.06, 0.945, "\n".join(lines), va="top", fontsize=8, linespacing=1.4)
    if est is not None:
        # one panel per sensor: six channels on one axes are unreadable
        sut = set(ctx.summary.get("channels", {}))
        groups = [("sensor under test", [i for i, c in enumerate(ids) if c in sut]),
                  ("reference", [i for i, c in enumerate(ids) if c not in sut])]
        groups = [(name, rows) for name, rows in groups if rows]
        height = 0.74 / len(groups)
        for k, (name, rows) in enumerate(groups):
            ax = fig.add_axes([0.1, 0.08 + (len(groups) - 1 - k) * height, 0.6,
                               height - 0.06])
            draw_estimates(ax, _rows(est, rows), [ids[i] for i in rows])
            ax.set_title(name, fontsize=9, loc="left")
    return fig
