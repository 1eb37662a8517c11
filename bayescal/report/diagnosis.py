"""One page (PDF and PNG) of a diagnosis: the findings in words, the
per-band misfit before and after, and the recorded/predicted ratio."""
from __future__ import annotations

import textwrap

import numpy as np

from .layout import page_size


def write_page(diagnosis, stem, paper="a4"):
    """Write ``stem.pdf`` and ``stem.png`` (one page of ``paper``, "a4" or
    "letter"); returns the two paths."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    d = diagnosis
    edges = np.asarray(d.band_edges)
    centres = np.sqrt(edges[:-1] * edges[1:])
    fig = plt.figure(figsize=page_size(paper))
    text = ["bayescal diagnose"] + [f"- {s}" for s in d.sentences()]
    if d.before["mismatch"]:
        text.append("Mismatch of the base model: " + "; ".join(
            f"{m['band_hz'][0]:.3g}-{m['band_hz'][1]:.3g} Hz on {', '.join(m['channels'])} "
            f"(p = {m['p_value']:.2g})" for m in d.before["mismatch"]))
    wrapped = "\n".join(textwrap.fill(t, 95) for t in text)
    fig.text(0.06, 0.97, wrapped, va="top", family="monospace", fontsize=7.5)
    ax1 = fig.add_axes([0.1, 0.42, 0.85, 0.25])
    ax2 = fig.add_axes([0.1, 0.08, 0.85, 0.25])
    for i, cid in enumerate(d.ids):
        line, = ax1.loglog(centres, d.before_common["misfit"][:, i], "o--",
                           label=f"{cid} base model")
        ax1.loglog(centres, d.after["misfit"][:, i], "s-", color=line.get_color(),
                   label=f"{cid} with the effects")
        ax2.semilogx(centres, np.degrees(np.angle(d.ratio_before[:, i])), "o--",
                     color=line.get_color(), label=f"{cid} phase before")
        ax2.semilogx(centres, 100 * (np.abs(d.ratio_before[:, i]) - 1), "^:",
                     color=line.get_color(), label=f"{cid} amplitude before (%)")
        if d.final is not d.base:
            ax2.semilogx(centres, np.degrees(np.angle(d.ratio_after[:, i])), "o-",
                         color=line.get_color(), alpha=0.6, label=f"{cid} phase with the effects")
            ax2.semilogx(centres, 100 * (np.abs(d.ratio_after[:, i]) - 1), "^-",
                         color=line.get_color(), alpha=0.6,
                         label=f"{cid} amplitude with the effects (%)")
    ax1.axhline(1.0, color="k", lw=0.8)
    ax1.set_ylabel("standardised misfit per band (1 = fits)")
    ax1.set_title("misfit before and after modelling the effects (both under the final "
                  "model's noise model)", fontsize=9)
    ax1.legend(fontsize=6, ncol=2)
    ax2.axhline(0.0, color="k", lw=0.8)
    ax2.set_xlabel("frequency (Hz)")
    ax2.set_ylabel("recorded / predicted: phase (deg), amplitude - 1 (%)")
    ax2.set_title("ratio of the SUT's recording to the prediction of the base model and of "
                  "the model with the effects", fontsize=9)
    ax2.legend(fontsize=6, ncol=2)
    paths = (f"{stem}.pdf", f"{stem}.png")
    fig.savefig(paths[0])
    fig.savefig(paths[1], dpi=80)
    plt.close(fig)
    return paths
