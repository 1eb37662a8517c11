"""One page (PDF and PNG) of a diagnosis: the findings in words, the
per-band misfit before and after, and the recorded/predicted ratio."""
from __future__ import annotations

import textwrap

import numpy as np

from ..criticism.diagnosis import check_misfits
from .layout import legend_beside, page_size, style, write_pages


def build_figure(diagnosis, paper="a4"):
    """The diagnosis page as a matplotlib ``Figure`` (no pyplot): the
    findings, then the per-band misfit and the recorded/predicted ratio
    against frequency. Each panel's legend sits beside it, outside the data,
    and is split into one entry per channel (colour) and one per line style
    (what the line shows), so it stays short however many channels."""
    from matplotlib.figure import Figure

    from .axes import log_ticks

    d = diagnosis
    edges = np.asarray(d.band_edges)
    fig = Figure(figsize=page_size(paper))
    fig.text(0.06, 0.965, "bayescal diagnose: what the model leaves out", fontsize=13,
             fontweight="bold")
    fig.text(0.06, 0.945, "\n".join(textwrap.fill(t, 115, subsequent_indent="  ")
                                     for t in _findings(d)), va="top", fontsize=7.5,
             linespacing=1.4)
    ax1 = fig.add_axes([0.13, 0.42, 0.58, 0.25])
    ax2 = fig.add_axes([0.13, 0.08, 0.58, 0.25])
    colours = _draw_curves(d, ax1, ax2, np.sqrt(edges[:-1] * edges[1:]))
    _label_panels(ax1, ax2, colours, after=d.final is not d.base)
    for ax in (ax1, ax2):
        log_ticks(ax, edges[0], edges[-1])
    return fig


def _findings(d):
    """The page's text: the diagnosis's sentences, a line when the final
    model's sampler did not converge, and the base model's mismatches."""
    from ..core.posterior import not_converged_line

    text = [f"- {s}" for s in d.sentences()]
    conv = getattr(d.final, "convergence", None)
    warn = None if conv is None or conv.converged else not_converged_line(
        conv.summary(), "the final model's sampler")
    if warn:
        text.insert(0, warn)
    if d.before["mismatch"]:
        text.append("Mismatch of the base model: " + "; ".join(
            f"{m['band_hz'][0]:.3g}-{m['band_hz'][1]:.3g} Hz on {', '.join(m['channels'])} "
            f"(p = {m['p_value']:.2g})" for m in d.before["mismatch"]))
    return text


def _draw_curves(d, ax1, ax2, centres):
    """Each channel's misfit (``ax1``) and recorded/predicted ratio
    (``ax2``) at the band centres; returns one legend entry per channel."""
    from matplotlib.lines import Line2D

    after = d.final is not d.base
    before_check, after_check = check_misfits(d)       # each model's own check
    colours = []
    for i, cid in enumerate(d.ids):
        line, = ax1.loglog(centres, before_check[:, i], "o--")
        c = line.get_color()
        colours.append(Line2D([], [], color=c, lw=2, label=cid))
        ax1.loglog(centres, after_check[:, i], "s-", color=c)
        ax2.semilogx(centres, np.degrees(np.angle(d.ratio_before[:, i])), "o--", color=c)
        ax2.semilogx(centres, 100 * (np.abs(d.ratio_before[:, i]) - 1), "^:", color=c)
        if after:
            ax2.semilogx(centres, np.degrees(np.angle(d.ratio_after[:, i])), "o-", color=c,
                         alpha=0.6)
            ax2.semilogx(centres, 100 * (np.abs(d.ratio_after[:, i]) - 1), "^-", color=c,
                         alpha=0.6)
    return colours


def _style(fmt, label):
    """A legend entry for a line style (``fmt`` as marker then line, e.g. ``"o--"``)."""
    from matplotlib.lines import Line2D

    return Line2D([], [], color="0.3", ls={"--": "--", ":": ":", "-": "-"}[fmt[1:]],
                  marker=fmt[0], mfc="white", label=label)


def _label_panels(ax1, ax2, colours, after):
    """Reference lines, axis labels, titles and legends of the two panels."""
    ax1.axhline(1.0, color="k", lw=0.8)
    ax1.set_ylabel("standardised misfit per band\n(1 = fits)", fontsize=8)
    ax1.set_title("misfit before and after modelling the effects (each model's own check)",
                  fontsize=8, loc="left")
    legend_beside(ax1, handles=colours + [_style("o--", "base model"),
                                          _style("s-", "with the effects")], fontsize=7)
    ax2.axhline(0.0, color="k", lw=0.8)
    ax2.set_xlabel("frequency (Hz)")
    ax2.set_ylabel("recorded / predicted:\nphase (deg), amplitude - 1 (%)", fontsize=8)
    ax2.set_title("ratio of the SUT's recording to the prediction of the base model and of "
                  "the model with the effects", fontsize=8, loc="left")
    styles = [_style("o--", "phase, base model"), _style("^:", "amplitude, base model")]
    if after:
        styles += [_style("o-", "phase, with the effects"),
                   _style("^-", "amplitude, with the effects")]
    legend_beside(ax2, handles=colours + styles, fontsize=7)


def write_page(diagnosis, stem, paper="a4"):
    """Write ``stem.pdf`` and ``stem.png`` (one page of ``paper``, "a4" or
    "letter"); returns the two paths."""
    paths = (f"{stem}.pdf", f"{stem}.png")
    with style():
        write_pages([(paths[1], build_figure(diagnosis, paper))], paths[0], dpi=80, grey=False)
    return paths
