"""Figures of the calibration report, one function per page (the corner plots are in :mod:`.corner_pages`).

Each ``page_<name>(ctx)`` returns a :class:`matplotlib.figure.Figure` (or
None when the page does not apply; page 1 a list of figures when it
continues on further pages). Figures are built without pyplot, so
rendering never needs a display. Conventions: angles in degrees (SEED),
frequencies in Hz on log axes, black-and-white friendly (line styles and
markers carry the distinctions, not colour alone), numbers written as text.

"""
from __future__ import annotations


import textwrap
from functools import partial

import numpy as np
from matplotlib.collections import LineCollection
from matplotlib.figure import Figure

from ..core.checks import describe
from ..criticism.verdict import lines as criticism_lines
from ..criticism.words import headline, posterior_text, self_noise_text
from ..core.posterior import multimodal_line
from ..result import Convergence
from .tables import (interval_row, angle_rows, response_rows, truth_values, two_pole_nominal,
                     wrap180)
from .axes import (log_ticks, parameter_label, placeholder_ids, psd_label,
                   trace_in_user_units)
from .layout import LINESTYLES, MARKERS, PARAM_UNITS, flow_text, header_lines, summary_table


def _page_top(fig, ctx):
    """Page 1's title, model check, modes line and header; returns where
    the tables start and the modes line (None without modes)."""
    fig.text(0.06, 0.965, "bayescal calibration report", fontsize=14, fontweight="bold")
    verdict = fit_check(ctx.summary)
    crit = ctx.summary.get("criticism") or {}
    check = textwrap.wrap(describe(verdict, next_step=crit.get("verdict_text") and
                                   f"Verdict: {crit['verdict_text']}."), 92)
    if headline(ctx.summary):
        check += textwrap.wrap(f"Reported: {headline(ctx.summary)}.", 92)
    fig.text(0.06, 0.945, "\n".join(check), va="top", fontsize=9 if verdict["ok"] is False else 8,
             fontweight="bold" if verdict["ok"] is False else "normal", linespacing=1.5)
    top = 0.945 - 0.0155 * len(check) - 0.008
    modes = multimodal_line(ctx.summary)
    if modes:
        wrapped = textwrap.wrap(modes, 92)
        fig.text(0.06, top, "\n".join(wrapped), va="top", fontsize=9, fontweight="bold",
                 linespacing=1.5)
        top -= 0.0155 * len(wrapped) + 0.008
    lines = header_lines(ctx)
    fig.text(0.06, top, "\n".join(lines), va="top", fontsize=8, linespacing=1.5)
    return top - 0.0143 * len(lines) - 0.02, modes


def page_summary(ctx):
    """Page 1: what was measured, the table of angles (and responses), flags
    and notes. Returns its figure, or a list of figures when the flags and
    notes run past the page's bottom margin (measured,
    :func:`~bayescal.report.layout.flow_text`): the rest on pages "page 1
    continued"."""
    post = ctx.post
    fig = Figure(figsize=ctx.page)
    top, modes = _page_top(fig, ctx)
    rows, flags = angle_rows(post, ctx.summary, ctx.tolerance_deg, ctx.truth)
    resp = response_rows(ctx.summary, ctx.truth)
    y = summary_table(fig, top, rows, "Orientation (SEED: azimuth clockwise from north, dip down "
                      "from horizontal; deviation = estimate - nominal)", bool(ctx.truth))
    if resp:
        gain_only = [c for c, e in ctx.summary["channels"].items() if e.get("response")
                     and not two_pole_nominal(e.get("nominal") or {})]
        y = summary_table(fig, y, resp, "Response (first-stage two-pole velocity sensor; deviation "
                          "in % of nominal)" if not gain_only else
                          "Response (gain-only metadata, e.g. 'flat': no nominal response to "
                          "deviate from; the fitted gain is the measurement)", bool(ctx.truth))
    text = _flag_lines(ctx, flags, modes)
    text.append("")
    text.append("Not estimable:" + ("" if post.not_estimable else " none"))
    for cid, reason in post.not_estimable.items():
        text.append(f"  {cid}: {reason}")
    text += ["", "Intervals are equal-tailed posterior quantiles (68 %: 16-84 %, 95 %: 2.5-97.5 %);"
             "\nazimuth intervals crossing north stay contiguous; a near-vertical channel's tilt and"
             " dip: the range of tilts\nin the credible region of its lean north/east components"
             " (lower bound 0 when the region holds the vertical).",
             "A near-vertical channel's azimuth is undefined: its tilt from the vertical is given"
             " instead, with the azimuth it leans toward."]
    if resp:
        text.append("Gain: first-stage sensitivity at its normalisation frequency, in the"
                    " StationXML's stage-1 output units (e.g. V) per m/s.")
    figs = flow_text(fig, 0.06, y, [ln for t in text for ln in t.split("\n")],
                     partial(_continued, ctx), fontsize=8, linespacing=1.35)
    return figs[0] if len(figs) == 1 else figs


def _continued(ctx):
    """A continuation page of page 1: its title; returns (figure, top)."""
    fig = Figure(figsize=ctx.page)
    fig.text(0.06, 0.965, "bayescal calibration report (page 1 continued)", fontsize=14,
             fontweight="bold")
    return fig, 0.94


def fit_check(summary):
    """The fit's own model check: the rejected fit's when the improved model
    heads the result, else the result's."""
    return ((summary.get("rejected_fit") or {}).get("adequacy") or summary.get("adequacy")
            or {"ok": None})


def _flag_lines(ctx, flags, modes):
    """Page 1's flags: the model check and criticism, modes, angles off
    nominal, what the prior set, the reference's noise, the record, the
    sensor order and the sampler."""
    verdict = fit_check(ctx.summary)
    crit = ctx.summary.get("criticism") or {}
    text = [f"Flags (tolerance {ctx.tolerance_deg:g} deg on azimuth, dip and tilt; flagged when the"
            " 95 % interval excludes nominal too):"]
    if headline(ctx.summary):
        text += textwrap.wrap(f"  ESTIMATES UNDER THE IMPROVED MODEL: {headline(ctx.summary)} "
                              "(the rejected fit's table: page \"rejected fit\")", 130,
                              subsequent_indent="      ")
    if self_noise_text(ctx.summary):
        text += textwrap.wrap(f"  {self_noise_text(ctx.summary)}", 130,
                              subsequent_indent="      ")
    if verdict["ok"] is False and crit:
        text.append("  MODEL CHECK FAILED; what the criticism found (the verdict is in the first "
                    "lines):")
        for line in criticism_lines(crit)[1:]:
            text += textwrap.wrap(line, 130, subsequent_indent="      ")
    elif verdict["ok"] is False:
        text.append("  MODEL CHECK FAILED: the misfit exceeds the noise model (see the first lines"
                    " and the page \"Data and fit\"; `bayescal diagnose`)")
    elif crit.get("effects"):       # the model fits, but the metadata need correcting
        for line in criticism_lines(crit):
            text += textwrap.wrap(f"  {line}", 130, subsequent_indent="      ")
    if modes:
        text.append("  MULTIMODAL POSTERIOR: intervals marked \"multimodal\" hold one mode only"
                    " (result.json: \"multimodal\")")
    for cid in ctx.post.channel_ids:
        for msg in flags.get(cid, []):
            text.append(f"  {cid}: {msg}")
    for cid, params in ctx.summary.get("set_by_prior", {}).items():
        for name, why in params.items():
            text += textwrap.wrap(f"  {cid}: {name} SET BY THE PRIOR, not measured: {why}", 130,
                                  subsequent_indent="    ")
        combo = ctx.summary["channels"].get(cid, {}).get("response", {}).get("damping_over_period")
        if combo and not combo.get("set_by_prior") and {"period_s", "damping"} & set(params):
            text.append(f"  {cid}: the data fix damping/period = {combo['median']:.4g} "
                        f"[{combo['ci95'][0]:.4g}, {combo['ci95'][1]:.4g}] 1/s (95 %), which "
                        "the corrected StationXML's poles carry")
    if len(text) == 1:
        text.append("  none: every estimated angle lies within tolerance of its nominal value")
    rn = ctx.summary.get("meta", {}).get("reference_noise", {})
    for note in (rn.get("separation", {}).get("note"), rn.get("gain_bounds", {}).get("note")):
        if note:
            text += textwrap.wrap(f"  Reference noise: {note}", 130, subsequent_indent="    ")
    short = ctx.summary.get("meta", {}).get("record_length", {}).get("note")
    if short:
        text += textwrap.wrap(f"  Record: {short}", 130, subsequent_indent="    ")
    order = ctx.summary.get("sensor_order", {})
    if order.get("message"):
        text.append(f"  WARNING: {order['message']}")
    elif order.get("caution"):
        text += textwrap.wrap(f"  Sensor order: {order['caution']}", 130,
                              subsequent_indent="    ")
    if not ctx.summary["convergence"]["converged"]:
        text.append("  SAMPLER NOT CONVERGED: treat every interval as provisional (see the convergence page)")
    return text


def _channel_panels(ctx, k):
    """Per channel: list of (label, result.json entry, nominal, truth) panels.
    The intervals are result.json's (one source for every number printed);
    an azimuth's nominal and truth are moved next to its median (by 360 deg)."""
    post = ctx.post
    cid, kind = post.channel_ids[k], post.kinds[k]
    ch = ctx.summary["channels"][cid]
    nom = ch.get("nominal") or {}
    tru = truth_values(ctx.truth, cid)
    panels = []
    if "tilt_deg" in ch:
        ntilt = 90.0 - abs(nom["dip_deg"]) if "dip_deg" in nom else None
        ttilt = 90.0 - abs(tru["dip_deg"]) if "dip_deg" in tru else None
        panels.append(("tilt from vertical (deg)", ch["tilt_deg"], ntilt, ttilt))
    elif kind != "fixed":
        az = ch["azimuth_deg"]
        naz, t, med = nom.get("azimuth_deg"), tru.get("azimuth_deg"), az["median"]
        panels.append(("azimuth (deg)", az,
                       None if naz is None else med - float(wrap180(med - naz)),
                       None if t is None else med - float(wrap180(med - t))))
    if kind == "sphere":
        panels.append(("dip (deg)", ch["dip_deg"], nom.get("dip_deg"), tru.get("dip_deg")))
    return panels


def _interval_panel(ax, label, entry, nominal, truth, tol):
    """One angle's median, 68 % and 95 % intervals (result.json's ``entry``)
    against its nominal value and the tolerance band."""
    med, (lo68, hi68), (lo95, hi95) = entry["median"], entry["ci68"], entry["ci95"]
    ax.plot([lo95, hi95], [0, 0], color="k", lw=1.0, solid_capstyle="butt")
    ax.plot([lo95, lo95], [-0.15, 0.15], color="k", lw=1.0)
    ax.plot([hi95, hi95], [-0.15, 0.15], color="k", lw=1.0)
    ax.plot([lo68, hi68], [0, 0], color="k", lw=5.0, solid_capstyle="butt")
    ax.plot([med], [0], "o", mfc="white", mec="k", ms=6, zorder=5)
    pts = [lo95, hi95]
    if nominal is not None:
        ax.axvline(nominal, color="0.3", ls="--", lw=1.0)
        for a, b in ((nominal - tol - 1e3, nominal - tol), (nominal + tol, nominal + tol + 1e3)):
            ax.axvspan(a, b, facecolor="none", edgecolor="0.7", hatch="////", lw=0, zorder=0)
        pts.append(nominal)
    if truth is not None:
        ax.plot([truth], [0.45], "v", color="k", ms=7)
        pts.append(truth)
    span = max(pts) - min(pts)
    pad = 0.15 * span if span > 0 else 0.1
    ax.set_xlim(min(pts) - pad, max(pts) + pad)
    ax.set_ylim(-1, 1)
    ax.set_yticks([])
    ax.set_xlabel(label)
    ax.ticklabel_format(axis="x", useOffset=False)
    txt = f"median {med:.2f}, 68 % [{lo68:.2f}, {hi68:.2f}], 95 % [{lo95:.2f}, {hi95:.2f}]"
    if nominal is not None:
        txt += f", nominal {nominal:.2f}"
    ax.text(0.01, 0.93, txt, transform=ax.transAxes, va="top", fontsize=6.5,
            bbox={"facecolor": "white", "edgecolor": "none", "pad": 1.0})


def page_intervals(ctx):
    """Page 2: per channel, the credible intervals of each angle against the
    nominal value and the tolerance band; None when no angle was estimated."""
    from matplotlib.lines import Line2D
    from matplotlib.patches import Patch

    post = ctx.post
    n = len(post.channel_ids)
    if not any(_channel_panels(ctx, k) for k in range(n)):
        return None   # no angle estimated (e.g. a vertical fixed to a vertical): no empty page
    fig = Figure(figsize=(ctx.page[0], min(ctx.page[1], 1.5 + 1.6 * n)))
    gs = fig.add_gridspec(n, 2, left=0.06, right=0.97, top=1 - 1.0 / fig.get_figheight(),
                          bottom=0.5 / fig.get_figheight(), hspace=0.9, wspace=0.12)
    for k, cid in enumerate(post.channel_ids):
        panels = _channel_panels(ctx, k)
        for j in range(2):
            ax = fig.add_subplot(gs[k, j])
            if j < len(panels):
                _interval_panel(ax, *panels[j], ctx.tolerance_deg)
            else:
                ax.axis("off")
                msg = ("dip not estimated: the channel is held in the reference's plane"
                       if post.kinds[k] == "circle" else
                       "direction held along the reference axis: not estimated" if j == 0 else "")
                ax.text(0.5, 0.5, msg, ha="center", va="center", transform=ax.transAxes)
            if j == 0:
                ax.set_title(cid, loc="left", fontweight="bold")
    handles = [Line2D([], [], marker="o", mfc="white", mec="k", ls="none", label="median"),
               Line2D([], [], color="k", lw=5, label="68 % interval"),
               Line2D([], [], color="k", lw=1, label="95 % interval"),
               Line2D([], [], color="0.3", ls="--", label="nominal (StationXML)"),
               Patch(facecolor="none", edgecolor="0.6", hatch="////",
                     label=f"beyond nominal +/- {ctx.tolerance_deg:g} deg (tolerance)")]
    if ctx.truth:
        handles.append(Line2D([], [], marker="v", color="k", ls="none", label="simulation truth"))
    fig.legend(handles=handles, loc="upper center", ncol=len(handles), frameon=False,
               bbox_to_anchor=(0.5, 1 - 0.05 / fig.get_figheight()))
    fig.text(0.5, 1 - 0.45 / fig.get_figheight(), "Angle credible intervals against nominal",
             ha="center", fontsize=11, fontweight="bold")
    if any("tilt_deg" in ctx.summary["channels"][c] for c in post.channel_ids):
        fig.text(0.06, 0.1 / fig.get_figheight(), "Intervals as in result.json and page 1; a "
                 "near-vertical channel's tilt and dip: the range of tilts in the credible "
                 "region of its lean\nnorth/east components (lower bound 0 when the region "
                 "holds the vertical).", fontsize=6.5)
    return fig


def misfit_range(n_r, p=0.95):
    """Central ``p`` range of a band misfit for a model that fits: the mean of
    ``n_r`` unit-variance complex Gaussian energies, Gamma(n_r, 1/n_r). The
    shape counts reference channels: Erlang, whose CDF is closed (``1 -
    exp(-y) sum_{k<n_r} y^k / k!``, ``y = n_r x``), its quantiles bisected
    to machine precision (no scipy import for two numbers)."""
    n = int(n_r)
    k = np.arange(n)
    factorial = np.cumprod(np.r_[1.0, np.arange(1.0, n)])

    def cdf(x):
        y = n * x[:, None]
        return 1.0 - np.exp(-y[:, 0]) * np.sum(y ** k / factorial, axis=1)

    target = np.array([(1 - p) / 2, (1 + p) / 2])
    lo, hi = np.zeros(2), np.full(2, 50.0)       # the mean is 1; its 97.5 % point below 3.7
    for _ in range(200):
        mid = 0.5 * (lo + hi)
        below = cdf(mid) < target
        lo, hi = np.where(below, mid, lo), np.where(below, hi, mid)
    return float(lo[0]), float(hi[1])


def page_data_fit(ctx):
    """Page 4: PSDs of both sensors, multiple coherence, per-band misfit."""
    d = ctx.post.diagnostics
    if not d:
        fig = Figure(figsize=ctx.page)
        fig.text(0.1, 0.9, "Data and fit: no diagnostics.npz in the result folder", fontsize=11)
        return fig
    f = d["freqs"]
    sut = [str(s) for s in d["sut_ids"]]
    ref = [str(s) for s in d["ref_ids"]]
    fig = Figure(figsize=ctx.page)
    gs = fig.add_gridspec(3, 1, left=0.11, right=0.96, top=0.93, bottom=0.06, hspace=0.35)
    fig.text(0.5, 0.965, "Data and fit", ha="center", fontsize=11, fontweight="bold")
    ax = fig.add_subplot(gs[0])
    psd = d["psd"]
    for i, cid in enumerate(sut + ref):
        is_ref = i >= len(sut)
        j = i - len(sut) if is_ref else i
        ax.loglog(f, psd[i], color="0.55" if is_ref else "k", lw=0.9,
                  ls=LINESTYLES[j % len(LINESTYLES)], label=f"{'REF' if is_ref else 'SUT'} {cid}")
    ax.set_xlabel("frequency (Hz)")
    ax.set_ylabel(psd_label(ctx.post.meta, sut + ref))
    flat = placeholder_ids(ctx.post.meta) & set(sut + ref)
    ax.set_title(("Power spectra, ground velocity (metadata responses removed)" if not flat else
                  "Power spectra as recorded ('flat' metadata: no response removed)"
                  if flat >= set(sut + ref) else
                  "Power spectra (metadata responses removed; 'flat' channels as recorded)")
                 + "; SUT black, reference grey", loc="left")
    ax.legend(ncol=2, loc="best")
    log_ticks(ax, f[0], f[-1])
    log_ticks(ax, axis="y")
    ax = fig.add_subplot(gs[1])
    incoherent = np.clip(1.0 - d["multiple_coherence"], 1e-8, 1.0)
    for i, cid in enumerate(sut):
        ax.loglog(f, incoherent[i], color="k", lw=0.8, ls=LINESTYLES[i % len(LINESTYLES)],
                  label=f"{cid} (median coherence {np.median(d['multiple_coherence'][i]):.4f})")
    ax.set_xlabel("frequency (Hz)")
    ax.set_ylabel("1 - squared multiple coherence (-)")
    ax.set_title("Incoherent fraction of each SUT channel's power, against all reference channels"
                 " (0.01 = coherence 0.99)", loc="left")
    ax.legend(loc="best")
    log_ticks(ax, f[0], f[-1])
    log_ticks(ax, axis="y")
    _misfit_panel(fig.add_subplot(gs[2]), d, sut, len(ref))
    return fig


def _misfit_panel(ax, d, sut, n_r):
    if "band_misfit" not in d:   # the one-angle grid posterior profiles each band's noise out
        ax.axis("off")
        ax.text(0.0, 0.5, "No per-band misfit: one reference channel, the SUT's horizontals "
                "rotated together (orthogonality assumed).", transform=ax.transAxes)
        return
    edges = d["band_edges"]
    centres = np.sqrt(edges[:-1] * edges[1:])
    mis = d["band_misfit"]
    lo, hi = misfit_range(n_r)
    ax.axhspan(lo, hi, facecolor="none", edgecolor="0.75", hatch="////", lw=0,
               label=f"95 % range if the model fits ({lo:.2f}-{hi:.2f})")
    ax.axhline(1.0, color="0.4", ls="--", lw=1, label="expectation (1)")
    for i, cid in enumerate(sut):
        ax.semilogx(centres, mis[:, i], color="k", lw=0.8, ls=LINESTYLES[i % len(LINESTYLES)],
                    marker=MARKERS[i % len(MARKERS)], mfc="white", ms=5,
                    label=f"{cid} (median {np.median(mis[:, i]):.2f})")
    for e in edges:
        ax.axvline(e, color="0.85", lw=0.5, zorder=0)
    ax.set_xlabel("frequency (Hz), band centres; thin lines: band edges")
    ax.set_ylabel("standardised misfit (-)")
    ax.set_title("Per-band residual energy over its noise model, per SUT channel",
                 loc="left")
    top = float(np.nanmax(mis))
    if top > 10 * hi:                    # far off: a log axis keeps the expected range visible
        ax.set_yscale("log")
        ax.set_ylim(min(lo, float(np.nanmin(mis))) / 1.5, top * 2)
        log_ticks(ax, axis="y")
    else:
        ax.set_ylim(0, max(hi * 1.3, top * 1.15))
    ax.legend(loc="upper left", ncol=2)
    log_ticks(ax, edges[0], edges[-1])


def page_convergence(ctx):
    """Page 5: trace plots and the convergence table."""
    post = ctx.post
    nd = len(post.names)
    fig = Figure(figsize=ctx.page)
    fig.text(0.5, 0.97, "Convergence of the sampler", ha="center", fontsize=11, fontweight="bold")
    if posterior_text(ctx.summary):      # no chain: no traces, no ESS or R-hat
        fig.text(0.06, 0.9, "\n".join(textwrap.wrap(posterior_text(ctx.summary), 100)),
                 va="top", fontsize=9)
        return fig
    n_rows = int(np.ceil(nd / 2))
    trace_h = min(0.55, 0.16 * n_rows + 0.03)
    table_h = 0.0135 * (nd + 1)
    table_top = 0.93 - trace_h - 0.085
    if post.trace is not None:
        _trace_panels(fig, ctx, n_rows, trace_h)
    _convergence_table(fig, ctx, table_top, table_h)
    from ..core.posterior import describe_sampler
    sampler = describe_sampler(post.meta.sampler)
    fig.text(0.06, 0.015, (textwrap.fill(f"Sampler: {sampler}", 150) + "\n" if sampler else "")
             + "Converged means: the chain kept after burn-in is at least 50 times its "
             "autocorrelation time (tau), every parameter has at least 1000\neffective samples "
             "(ESS), and the two halves of the chain agree (split R-hat below 1.01).",
             fontsize=6.5)
    return fig


def _trace_panels(fig, ctx, n_rows, trace_h):
    """Page 5's trace plots of up to 8 walkers, one panel a parameter."""
    post, names = ctx.post, ctx.post.names
    nd = len(names)
    conv = ctx.summary["convergence"]
    gs = fig.add_gridspec(n_rows, 2, left=0.1, right=0.97, top=0.93,
                          bottom=0.93 - trace_h, hspace=0.15, wspace=0.3)
    tr = post.trace
    step = max(1, tr.shape[0] // 200)
    x = np.arange(tr.shape[0])[::step] * conv["n_steps"] / tr.shape[0]
    walkers = np.linspace(0, tr.shape[1] - 1, min(8, tr.shape[1])).astype(int)
    burn = post.convergence.burn
    nominal = post.meta.nominal or {}
    for p, name in enumerate(names):
        ax = fig.add_subplot(gs[p // 2, p % 2])
        values, unit = trace_in_user_units(name, tr[::step, walkers, p].T,
                                           nominal.get(name.rsplit(":", 1)[0]))
        segs = np.stack([np.broadcast_to(x, (walkers.size, x.size)), values], axis=-1)
        ax.add_collection(LineCollection(segs, colors="k", linewidths=0.4, alpha=0.6))
        ax.autoscale_view()
        ax.margins(y=0.35)
        if burn is not None:
            ax.axvline(float(burn), color="k", ls="--", lw=0.8)
        ax.text(0.01, 0.96, parameter_label(name), transform=ax.transAxes, fontsize=6, va="top",
                bbox={"facecolor": "white", "edgecolor": "none", "pad": 0.8, "alpha": 0.85})
        ax.set_ylabel(unit or PARAM_UNITS.get(name.split(":")[-1], ""), fontsize=6)
        ax.tick_params(labelsize=6)
        if p >= nd - 2:
            ax.set_xlabel("step")
        else:
            ax.tick_params(labelbottom=False)
    fig.text(0.1, 0.93 - trace_h - 0.045,
             f"Traces of {len(walkers)} of {tr.shape[1]} walkers: axis direction in deg from "
             "the sampler's start axis (two offsets), or azimuth in deg;\nperiod in s, gain in % "
             "off metadata; dashed line: end of burn-in (samples after it are kept).",
             fontsize=7, va="top")


def _convergence_table(fig, ctx, table_top, table_h):
    """Page 5's table of every parameter's tau, ESS and split R-hat."""
    names = ctx.post.names
    conv = ctx.summary["convergence"]
    ax = fig.add_axes([0.06, table_top - table_h, 0.6, table_h])
    ax.axis("off")
    per = conv["per_parameter"]
    cells = [[parameter_label(n), f"{per[n]['tau']:.1f}", f"{per[n]['ess']:.0f}",
              f"{per[n]['rhat']:.4f}"] for n in names]
    ax.set_title(
        f"Acceptance fraction {conv['acceptance']:.3f}; {conv['n_walkers']} walkers x"
        f" {conv['n_steps']} steps; autocorrelation time up to {conv['tau_max']:.1f} steps; {Convergence.figures(conv)};"
        f" converged: {'yes' if conv['converged'] else 'NO'}",
        loc="left", fontsize=7)
    tab = ax.table(cellText=cells, colLabels=["parameter", "tau (steps)", "ESS", "split R-hat"],
                   loc="upper left", cellLoc="left", colLoc="left", edges="horizontal",
                   bbox=[0, 0, 1, 1])
    tab.auto_set_font_size(False)
    tab.set_fontsize(7)
    tab.auto_set_column_width([0, 1, 2, 3])


__all__ = ["page_summary", "page_intervals", "page_data_fit", "page_convergence"]


def _rejected_angle_rows(channels, truth):
    """Summary-table rows of the angles of the rejected fit's ``channels``
    (result.json's ``rejected_fit``), deviations from nominal."""
    rows = []
    for cid, ch in channels.items():
        nom, tru = ch.get("nominal") or {}, truth_values(truth, cid)
        az, dip = ch.get("azimuth_deg", {}), ch.get("dip_deg", {})
        if "tilt_deg" in ch:
            ntilt = None if nom.get("dip_deg") is None else 90.0 - abs(nom["dip_deg"])
            t = ch["tilt_deg"]
            rows.append(interval_row(cid, "tilt", t, ntilt, None if ntilt is None else
                                      t["median"] - ntilt, "", None if "dip_deg" not in tru
                                      else 90.0 - abs(tru["dip_deg"])))
        elif "ci95" in az and not az.get("undefined"):
            naz = nom.get("azimuth_deg")
            rows.append(interval_row(cid, "azimuth", az, naz, None if naz is None else
                                      float(wrap180(az["median"] - naz)), "",
                                      tru.get("azimuth_deg")))
        if "ci95" in dip:
            ndip = nom.get("dip_deg")
            rows.append(interval_row(cid, "dip", dip, ndip, None if ndip is None else
                                      dip["median"] - ndip, "", tru.get("dip_deg")))
    return rows


def page_rejected_fit(ctx):
    """The fit the criticism's verdict rejected (result.json's
    ``rejected_fit``), when the improved model heads the result: its table,
    model check and convergence; None otherwise."""
    rejected = ctx.summary.get("rejected_fit")
    if not rejected:
        return None
    nxt = "The criticism's verdict, on page 1, chose the improved model."
    fig = Figure(figsize=ctx.page)
    fig.text(0.06, 0.965, "The rejected fit (not the estimates reported)", fontsize=14,
             fontweight="bold")
    head = textwrap.wrap(f"Reported instead: {headline(ctx.summary)}. This fit, under the model "
                         f"without those effects: {describe(rejected['adequacy'], next_step=nxt)}", 100)
    fig.text(0.06, 0.94, "\n".join(head), va="top", fontsize=8, linespacing=1.5)
    top = 0.94 - 0.0145 * len(head) - 0.02
    y = summary_table(fig, top, _rejected_angle_rows(rejected["channels"], ctx.truth),
                      "Orientation under the rejected fit (deviation = estimate - nominal)",
                      bool(ctx.truth))
    resp = response_rows({"channels": rejected["channels"]}, ctx.truth)
    if resp:
        y = summary_table(fig, y, resp, "Response under the rejected fit", bool(ctx.truth))
    c = rejected.get("convergence") or {}
    if c:
        fig.text(0.06, y, f"Its sampler: {Convergence.figures(c)}, autocorrelation time up to {c['tau_max']:.1f} steps, "
                 f"{c['n_steps']} steps.", va="top", fontsize=8)
    return fig
