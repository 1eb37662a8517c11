"""One page (PDF and PNG) of a diagnosis: the findings in words, the
per-band misfit before and after, and the recorded/predicted ratio."""
from __future__ import annotations

import textwrap

import numpy as np

from .layout import page_size


def build_figure(diagnosis, paper="a4"):
    """The diagnosis page as a matplotlib ``Figure`` (no pyplot): the
    findings, then the per-band misfit and the recorded/predicted ratio
    against frequency. Each panel's legend sits beside it, outside the data,
    and is split into one entry per channel (colour) and one per line style
    (what the line shows), so it stays short however many channels."""
    from matplotlib.figure import Figure
    from matplotlib.lines import Line2D

    from .axes import frequency_ticks

    d = diagnosis
    edges = np.asarray(d.band_edges)
    centres = np.sqrt(edges[:-1] * edges[1:])
    fig = Figure(figsize=page_size(paper))
    text = ["bayescal diagnose"] + [f"- {s}" for s in d.sentences()]
    from ..core.posterior import not_converged_line
    conv = getattr(d.final, "convergence", None) or {}
    warn = None if conv.get("converged", True) else not_converged_line(
        {"converged": False, "n_steps": conv["n_steps"], "ess_min": float(np.min(conv["ess"])),
         "rhat_max": float(np.max(conv["rhat"]))}, "the final model's sampler")
    if warn:
        text.insert(1, warn)
    if d.before["mismatch"]:
        text.append("Mismatch of the base model: " + "; ".join(
            f"{m['band_hz'][0]:.3g}-{m['band_hz'][1]:.3g} Hz on {', '.join(m['channels'])} "
            f"(p = {m['p_value']:.2g})" for m in d.before["mismatch"]))
    wrapped = "\n".join(textwrap.fill(t, 95) for t in text)
    fig.text(0.06, 0.97, wrapped, va="top", family="monospace", fontsize=7.5)
    ax1 = fig.add_axes([0.13, 0.42, 0.58, 0.25])
    ax2 = fig.add_axes([0.13, 0.08, 0.58, 0.25])
    after = d.final is not d.base
    colours = []
    for i, cid in enumerate(d.ids):
        line, = ax1.loglog(centres, d.before_common["misfit"][:, i], "o--")
        c = line.get_color()
        colours.append(Line2D([], [], color=c, lw=2, label=cid))
        ax1.loglog(centres, d.after["misfit"][:, i], "s-", color=c)
        ax2.semilogx(centres, np.degrees(np.angle(d.ratio_before[:, i])), "o--", color=c)
        ax2.semilogx(centres, 100 * (np.abs(d.ratio_before[:, i]) - 1), "^:", color=c)
        if after:
            ax2.semilogx(centres, np.degrees(np.angle(d.ratio_after[:, i])), "o-", color=c,
                         alpha=0.6)
            ax2.semilogx(centres, 100 * (np.abs(d.ratio_after[:, i]) - 1), "^-", color=c,
                         alpha=0.6)

    def style(fmt, label):
        return Line2D([], [], color="0.3", ls={"--": "--", ":": ":", "-": "-"}[fmt[1:]],
                      marker=fmt[0], mfc="white", label=label)

    ax1.axhline(1.0, color="k", lw=0.8)
    ax1.set_ylabel("standardised misfit per band\n(1 = fits)", fontsize=8)
    ax1.set_title("misfit before and after modelling the effects (both under the final "
                  "model's noise model)", fontsize=8, loc="left")
    ax1.legend(handles=colours + [style("o--", "base model"), style("s-", "with the effects")],
               fontsize=7, loc="upper left", bbox_to_anchor=(1.02, 1.0), borderaxespad=0.0)
    ax2.axhline(0.0, color="k", lw=0.8)
    ax2.set_xlabel("frequency (Hz)")
    ax2.set_ylabel("recorded / predicted:\nphase (deg), amplitude - 1 (%)", fontsize=8)
    ax2.set_title("ratio of the SUT's recording to the prediction of the base model and of "
                  "the model with the effects", fontsize=8, loc="left")
    styles = [style("o--", "phase, base model"), style("^:", "amplitude, base model")]
    if after:
        styles += [style("o-", "phase, with the effects"),
                   style("^-", "amplitude, with the effects")]
    ax2.legend(handles=colours + styles, fontsize=7, loc="upper left",
               bbox_to_anchor=(1.02, 1.0), borderaxespad=0.0)
    for ax in (ax1, ax2):
        frequency_ticks(ax, edges[0], edges[-1])
    return fig


def write_page(diagnosis, stem, paper="a4"):
    """Write ``stem.pdf`` and ``stem.png`` (one page of ``paper``, "a4" or
    "letter"); returns the two paths."""
    fig = build_figure(diagnosis, paper)
    paths = (f"{stem}.pdf", f"{stem}.png")
    fig.savefig(paths[0])
    fig.savefig(paths[1], dpi=80)
    return paths
