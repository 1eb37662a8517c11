"""The report's page of the response as the data see it: each SUT
channel's response relative to the reference's metadata under the headline
model (result.json's ``response_curve``,
:mod:`bayescal.pair.response_curve`), amplitude and phase against log
frequency with its 95 % band, beside the same ratio from the metadata
alone; a clock effect is stated as the time correction of the data it is.
"""
from __future__ import annotations

import textwrap

import numpy as np
from matplotlib.figure import Figure

from .axes import log_ticks
from .layout import LINESTYLES


def _under(summary):
    """Under which model the curve is, in words."""
    head = (summary.get("meta") or {}).get("headline") or {}
    if head.get("model") == "improved":
        return f"the criticism's improved model ({head.get('label') or ', '.join(head['effects'])})"
    return "the fit's model"


def curve_note(summary):
    """The page's text: what the curve is, under which model, and the time
    correction when the model has a clock effect."""
    curve = summary["response_curve"]
    refs = sorted({e["reference"] for e in curve["channels"].values()})
    text = (f"R(f) = H_SUT(f) / H_REF,metadata(f) (counts over counts) under {_under(summary)}: "
            "the SUT's response as the recordings see it, relative to the reference's metadata "
            f"({', '.join(refs)}). A pair sees only this ratio: a pole missing from the "
            "reference's metadata shows as a zero of the SUT's. Black: posterior median, grey: "
            "95 % band; dashed: the same ratio from the two metadata alone.")
    clock = curve.get("time_correction")
    if clock:
        text += f" Not response: {clock['text']}."
    return text


def _panel(ax_amp, ax_ph, f, entry, cid, k):
    """One channel's amplitude and phase panels."""
    for ax, key in ((ax_amp, "amplitude"), (ax_ph, "phase_rad")):
        e = entry[key]
        lo, hi = (np.asarray(x, float) for x in e["ci95"])
        ax.fill_between(f, lo, hi, color="0.8", lw=0, label="95 % band")
        ax.plot(f, np.asarray(e["median"], float), color="k", lw=1.0,
                ls=LINESTYLES[k % len(LINESTYLES)], label=f"{cid} / {entry['reference']}: median")
        ax.plot(f, np.asarray(entry["metadata"][key], float), color="0.4", lw=1.0, ls="--",
                label="metadata")
        ax.set_xscale("log")
        log_ticks(ax, f[0], f[-1])
        ax.set_xlabel("frequency (Hz)")
    ax_amp.set_yscale("log")
    log_ticks(ax_amp, axis="y")
    ax_amp.set_ylabel("|R| (counts / counts)")
    ax_ph.set_ylabel("phase of R (rad)")
    ax_amp.set_title(cid, loc="left", fontsize=8)
    ax_amp.legend(loc="best", fontsize=6)


def page_response_curve(ctx):
    """The relative response curve of every SUT channel (module docstring);
    None when the result holds none."""
    curve = ctx.summary.get("response_curve")
    if not curve or not curve.get("channels"):
        return None
    f = np.asarray(curve["freq_hz"], float)
    ids = list(curve["channels"])
    fig = Figure(figsize=ctx.page)
    fig.text(0.06, 0.965, "The SUT's response as the data see it", fontsize=14,
             fontweight="bold")
    note = textwrap.wrap(curve_note(ctx.summary), 110)
    fig.text(0.06, 0.945, "\n".join(note), va="top", fontsize=7.5, linespacing=1.45)
    top = 0.945 - 0.0135 * len(note) - 0.03
    gs = fig.add_gridspec(len(ids), 2, left=0.1, right=0.97, top=top, bottom=0.06,
                          hspace=0.55, wspace=0.3)
    for k, cid in enumerate(ids):
        _panel(fig.add_subplot(gs[k, 0]), fig.add_subplot(gs[k, 1]), f,
               curve["channels"][cid], cid, k)
    return fig
