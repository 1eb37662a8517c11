"""Corner-plot pages of the fit report: the angles jointly, and the response
parameters per channel (contour levels stated on the page).
"""
from __future__ import annotations


import numpy as np
from matplotlib.figure import Figure

from ..core.orientation import unit_vector
from ..core.posterior import sampled_azimuth_dip
from ..core.response import damping_over_period
from .tables import truth_values, wrap180
from .layout import CORNER_LEVELS, CORNER_QUANTILES, page_header


#: Most posterior draws a corner plot is drawn from: its histograms have 30
#: bins a side, smoothed over one bin, and more draws do not change what the
#: eye sees (the intervals printed on every page are result.json's, from all
#: draws).
CORNER_DRAWS = 5000


def thinned(data, most=CORNER_DRAWS):
    """Every k-th row of ``data`` (N, D), k the smallest stride that leaves
    at most ``most`` rows: the draws a corner plot is drawn from."""
    return data[::max(1, -(-len(data) // most))]


def _truth_or_nan(value):
    return np.nan if value is None else value


def angle_columns(ctx):
    """Corner-plot columns of the angles: (samples (N, D), labels, truths)."""
    post = ctx.post
    az, dip = sampled_azimuth_dip(post.vectors)
    cols, labels, truths = [], [], []
    for k, cid in enumerate(post.channel_ids):
        ch = ctx.summary["channels"][cid]
        tru = truth_values(ctx.truth, cid)
        short = cid.split(".")[-1]
        if post.kinds[k] == "fixed":
            continue
        if "tilt_deg" in ch:
            # near-vertical: the axis' North and East components as angles
            v = post.vectors[:, k] * -np.sign(post.vectors[:, k, 2:3])
            tv = None
            if "azimuth_deg" in tru:
                tv = unit_vector(tru["azimuth_deg"], tru["dip_deg"])
                tv = tv * -np.sign(tv[2])
            for j, comp in enumerate("NE"):
                cols.append(np.degrees(np.arcsin(v[:, j])))
                labels.append(f"{short} lean {comp} (deg)")
                truths.append(np.nan if tv is None else np.degrees(np.arcsin(tv[j])))
            continue
        med = np.median(az[:, k])
        cols.append(az[:, k])
        labels.append(f"{short} azimuth (deg)")
        t = tru.get("azimuth_deg")
        truths.append(np.nan if t is None else med - float(wrap180(med - t)))
        if post.kinds[k] == "sphere":
            cols.append(dip[:, k])
            labels.append(f"{short} dip (deg)")
            truths.append(_truth_or_nan(tru.get("dip_deg")))
    if not cols:
        return np.empty((post.vectors.shape[0], 0)), labels, truths
    return np.column_stack(cols), labels, truths


def response_columns(ctx):
    """Corner-plot columns of the fitted response parameters, one entry per
    channel: ``[(channel id, samples (N, D), labels, truths), ...]``."""
    post = ctx.post
    free = post.meta.free_response or "none"
    if free == "none" or not post.response:
        return []
    names = ("period_s", "damping", "gain") if free == "all" else ("gain",)
    out = []
    for cid in post.channel_ids:
        if cid not in post.response:
            continue
        gain_units = (ctx.summary["channels"].get(cid, {}).get("nominal") or {}).get("gain_units")
        units = {"period_s": "s", "damping": "-", "gain": gain_units or "stage-1 units per m/s"}
        tru = truth_values(ctx.truth, cid)
        idx = [j for j, n in enumerate(("period_s", "damping", "gain")) if n in names]
        # a parameter held at nominal (set by the prior) has nothing to draw
        idx = [j for j in idx if np.ptp(post.response[cid][:, j]) > 0]
        drawn = [("period_s", "damping", "gain")[j] for j in idx]
        if not idx:
            continue
        data = post.response[cid][:, idx]
        labels = [f"{n.replace('_s', '')} ({units[n]})" for n in drawn]
        truths = [_truth_or_nan(tru.get(n)) for n in drawn]
        if {"period_s", "damping"} <= set(drawn):
            # what a band above the corner fixes (bayescal.core.response.pendulum)
            r = post.response[cid]
            data = np.column_stack([data[:, :2], damping_over_period(r[:, 0], r[:, 1]),
                                    data[:, 2:]])
            labels.insert(2, "h/T0 (1/s)")
            truths.insert(2, tru["damping"] / tru["period_s"] if "period_s" in tru else np.nan)
        out.append((cid, data, labels, truths))
    return out


def _corner(fig, data, labels, truths, width, height, box):
    """Draw a corner plot into ``fig`` (a Figure or SubFigure of ``width`` x
    ``height`` inches) inside ``box`` = (left, bottom, right, top) margins in
    inches; axis labels sit at a fixed distance in inches so they stay on
    the page whatever the number of panels. Returns True if truths were drawn."""
    import corner
    import matplotlib

    data = thinned(data)
    k = data.shape[1]
    truths = None if truths is None or np.all(np.isnan(truths)) else list(truths)
    if k > 4:                                   # narrow panels: channel above quantity
        labels = [lb.replace(" ", "\n", 1) for lb in labels]
    with matplotlib.rc_context({"axes.grid": False}):    # grid lines: no use between contours
        corner.corner(data, fig=fig, labels=labels, levels=CORNER_LEVELS, quantiles=CORNER_QUANTILES,
                      truths=truths if k > 1 else None,   # corner cannot draw 1-D truths
                      truth_color="0.25", color="k", plot_datapoints=False, plot_density=False,
                      fill_contours=True, contourf_kwargs={"colors": ["white", "0.88", "0.7"]},
                      smooth=1.0, bins=30, max_n_ticks=3, label_kwargs={"fontsize": 7})
    axes = fig.axes
    if k == 1 and truths is not None:
        axes[0].axvline(truths[0], color="0.25")
    left, bottom, right, top = box
    fig.subplots_adjust(left=left / width, bottom=bottom / height, right=1 - right / width,
                        top=1 - top / height, wspace=0.08, hspace=0.08)
    pw = (1 - (left + right) / width) * width / k          # panel size, inches
    ph = (1 - (bottom + top) / height) * height / k
    for ax in axes:
        ax.xaxis.set_label_coords(0.5, -0.55 / ph)
        ax.yaxis.set_label_coords(-0.6 / pw, 0.5)
        ax.tick_params(labelsize=6 if k > 4 else 7)
    return truths is not None


def _draws_line(n):
    """The note's line on the draws drawn, for ``n`` posterior draws."""
    drawn = len(thinned(range(n)))
    return ("" if drawn == n else f"\nDrawn from {drawn} of the {n} posterior draws (one in "
            f"{-(-n // CORNER_DRAWS)}); the intervals printed on the other pages are from all.")


def _corner_note(truths_drawn, labels):
    lv = " and ".join(f"{100 * x:g} %" for x in CORNER_LEVELS)
    q = ", ".join(f"{100 * x:g}" for x in CORNER_QUANTILES)
    return (f"Contour levels drawn: {lv} of the 2-D posterior mass (explicit levels, not"
            f" corner's default 39 % '1 sigma'); shading: light inside 95 %, darker inside 68 %."
            f"\nDashed lines on the 1-D histograms: {q} % quantiles."
            + ("  Grey lines and squares: simulation truth." if truths_drawn else "")
            + ("\n'lean N/E': angle of a near-vertical channel's upward axis toward North/East"
               " (its azimuth is undefined)." if any("lean" in lb for lb in labels) else ""))


def page_corner_angles(ctx):
    """Page 3a: corner plot of the angles (degrees), all channels jointly."""
    data, labels, truths = angle_columns(ctx)
    if data.size == 0:
        return None
    k = data.shape[1]
    width = min(ctx.page[0], max(6.0, 1.45 * k + 1.2))
    box = (0.95, 0.95, 0.15, 1.3) if k > 4 else (0.8, 0.75, 0.15, 1.3)
    fig = Figure(figsize=(width, width + box[3] - box[1]))
    drawn = _corner(fig, data, labels, truths if ctx.truth else None, width,
                    fig.get_figheight(), box)
    page_header(fig, "Posterior of the orientation angles",
                _corner_note(drawn, labels) + _draws_line(len(data)), width)
    return fig


def page_corner_response(ctx):
    """Page 3b: corner plots of the fitted response parameters, one per
    channel (when fitted)."""
    blocks = response_columns(ctx)
    if not blocks:
        return None
    n = len(blocks)
    ncol = 1 if n == 1 else 2
    nrow = int(np.ceil(n / ncol))
    sub_w = ctx.page[0] / ncol
    sub_h = min(sub_w, (ctx.page[1] - 1.3) / nrow)
    fig = Figure(figsize=(ctx.page[0], 1.3 + sub_h * nrow))
    # a header band of 1.3 in, then the grid of per-channel subfigures
    gs = fig.add_gridspec(nrow + 1, ncol, height_ratios=[1.3] + [sub_h] * nrow,
                          left=0, right=1, top=1, bottom=0, hspace=0, wspace=0)
    subs = [fig.add_subfigure(gs[1 + i // ncol, i % ncol]) for i in range(n)]
    drawn = False
    for sf, (cid, data, labels, truths) in zip(subs, blocks):
        box = (0.8, 0.75, 0.2, 0.35)
        drawn |= _corner(sf, data, labels, truths if ctx.truth else None, sub_w, sub_h, box)
        sf.text(0.5, 1 - 0.12 / sub_h, cid, ha="center", va="top", fontweight="bold")
    page_header(fig, "Posterior of the response parameters, per channel",
            _corner_note(drawn, []) + _draws_line(len(blocks[0][1])) + "\nGain: first-stage sensitivity in the StationXML's"
            " stage-1 output units (e.g. V) per m/s."
            + ("\nh/T0: damping over period, what a band above the corner fixes; a period or"
               " damping set by the prior spreads along it." if any(
                   "h/T0 (1/s)" in b[2] for b in blocks) else ""), ctx.page[0])
    return fig
