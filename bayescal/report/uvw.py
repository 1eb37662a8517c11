"""Report pages of a UVW calibration (:class:`bayescal.coil.uvw.UVWResult`).

Three pages, each a PNG and a page of ``uvw_report.pdf``:

* ``uvw_elements.png``: each element's response over the nominal (amplitude
  ratio and phase difference) with its 90 % credible band, and the parameter
  table;
* ``uvw_xyz.png``: the XYZ responses ``diag(M^T diag(k) M)`` over the nominal
  and the cross-talk ``|T_lm| / sqrt(|T_ll T_mm|)`` against frequency, with
  90 % bands;
* ``uvw_agreement.png``: Z-only and all-output estimates side by side
  (median, 68 % and 95 % intervals) and the geometry check (apparent against
  expected output coefficients).

Bands are equal-tailed pointwise intervals over posterior samples.
"""
from __future__ import annotations

import os

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from matplotlib.backends.backend_pdf import PdfPages  # noqa: E402

from ..coil.uvw import ELEMENTS, PARAMS, XYZ, element_ratios  # noqa: E402
from .layout import page_size, save_pdf_page  # noqa: E402

COLOURS = {"U": "tab:blue", "V": "tab:orange", "W": "tab:green",
           "X": "tab:red", "Y": "tab:purple", "Z": "tab:brown"}
LABELS = {"period_s": "period (s)", "damping": "damping", "gain": "gain"}


def _band(ax, f, x, colour, label):
    lo, med, hi = np.percentile(x, [5, 50, 95], axis=0)
    ax.fill_between(f, lo, hi, color=colour, alpha=0.3, lw=0)
    ax.plot(f, med, color=colour, lw=1.2, label=label)


def _response_panels(fig, f, curves, title):
    """Amplitude ratio and phase difference (deg) of complex ``curves``
    (name -> (N, F))."""
    a1, a2 = fig.subplots(2, 1, sharex=True)
    for name, c in curves.items():
        _band(a1, f, np.abs(c), COLOURS[name], name)
        _band(a2, f, np.degrees(np.angle(c)), COLOURS[name], name)
    a1.set_xscale("log")
    a1.set_ylabel("amplitude / nominal")
    a2.set_ylabel("phase - nominal (deg)")
    a2.set_xlabel("frequency (Hz)")
    a1.set_title(title)
    a1.legend(fontsize=8)
    for a in (a1, a2):
        a.grid(True, which="both", alpha=0.3)


def _cell(entry, digits=5):
    """A table cell: median and 95 % interval, or that the prior sets it
    (a value the prior sets is not a measurement)."""
    if not entry:
        return "-"
    if entry.get("set_by_prior"):
        return "set by the prior\n(not measured)"
    lo, hi = entry["ci95"]
    return f"{entry['median']:.{digits}g}\n[{lo:.{digits}g}, {hi:.{digits}g}]"


def elements_page(result, summary, paper="a4"):
    """Element responses over the nominal with 90 % bands, and the table."""
    fig = plt.figure(figsize=page_size(paper, landscape=True))
    left, right = fig.subfigures(1, 2, width_ratios=[1.35, 1])
    k = element_ratios(result.joint, result.family, result.freqs)
    _response_panels(left, result.freqs, {e: k[:, j] for j, e in enumerate(ELEMENTS)},
                     "element responses (90 % bands)")
    ax = right.subplots()
    ax.axis("off")
    cols = (*PARAMS, "damping_over_period")
    rows = [[e] + [_cell(summary["elements"][e].get(p), 4 if p == "damping_over_period" else 5)
                   for p in cols] for e in ELEMENTS]
    tab = ax.table(cellText=rows, colLabels=["", "period (s)", "damping", "gain",
                                             "damping/period (1/s)"],
                   loc="upper center", cellLoc="center", colWidths=[0.08, 0.23, 0.23, 0.23, 0.23])
    tab.auto_set_font_size(False)
    tab.set_fontsize(6)
    tab.scale(1, 3)
    ax.set_title(f"medians [95 %]  ({summary['mode']})\ngain: {summary['gain_units']}",
                 fontsize=8)
    from ..core.posterior import not_converged_line
    lines = [not_converged_line(v["convergence"], what=f"the sampler of element {e}")
             for e, v in summary["elements"].items()]
    lines = [x for x in lines if x]
    if lines:
        fig.suptitle("\n".join(lines), fontsize=7, color="darkred")
    return fig


def xyz_page(result, summary, paper="a4"):
    """XYZ responses and cross-talk with 90 % bands."""
    fig = plt.figure(figsize=page_size(paper, landscape=True))
    left, right = fig.subfigures(1, 2)
    t = result.xyz["ratio"]
    _response_panels(left, result.freqs, {a: t[:, i, i] for i, a in enumerate(XYZ)},
                     "XYZ responses diag(M^T diag(k) M) (90 % bands)")
    ax = right.subplots()
    d = np.abs(np.einsum("nllf->nlf", t))
    for (i, j), col in zip([(0, 1), (0, 2), (1, 2)], ["tab:cyan", "tab:olive", "tab:gray"]):
        rel = np.abs(t[:, i, j]) / np.sqrt(d[:, i] * d[:, j])
        _band(ax, result.freqs, 100 * rel, col, f"{XYZ[i]}-{XYZ[j]}")
    ct = summary["cross_talk_max"]
    ax.set_xscale("log")
    ax.set_xlabel("frequency (Hz)")
    ax.set_ylabel("cross-talk |T_lm| / sqrt(|T_ll T_mm|) (%)")
    ax.set_title(f"largest cross-talk {100 * ct['median']:.3g} % "
                 f"[{100 * ct['ci95'][0]:.3g}, {100 * ct['ci95'][1]:.3g}]", fontsize=9)
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=8)
    return fig


def agreement_page(result, summary, paper="a4"):
    """Z-only against all-output estimates, and the geometry check."""
    fig, axes = plt.subplots(2, 3, figsize=page_size(paper, landscape=True))
    modes = [("all outputs" if summary["mode"] != "z-only" else "Z only", result.fits)]
    if result.z_fits:
        modes.append(("Z only", result.z_fits))
    for j, p in enumerate(PARAMS):
        ax = axes[0, j]
        for k, (label, fits) in enumerate(modes):
            for i, e in enumerate(ELEMENTS):
                x = fits[e].samples[:, j]
                q = np.percentile(x, [2.5, 16, 50, 84, 97.5])
                y = i + 0.15 * (k - 0.5 * (len(modes) - 1))
                col = "k" if k == 0 else "tab:red"
                ax.plot([q[0], q[4]], [y, y], color=col, lw=1)
                ax.plot([q[1], q[3]], [y, y], color=col, lw=3)
                ax.plot(q[2], y, "o", color=col, ms=4, label=label if i == 0 else None)
        ax.set_yticks(range(3), ELEMENTS)
        ax.set_title(LABELS[p] + (" (as fitted)" if p == "gain" else ""), fontsize=9)
        ax.grid(True, alpha=0.3)
    axes[0, 0].legend(fontsize=8)
    ag = summary.get("agreement")
    note = ag["note"] + f" (max |z| = {ag['max_abs_z']:.2f})" if ag else \
        "Z-only comparison not available (Z-only mode, or no Z output)"
    fig.suptitle(note, fontsize=10)
    ax = axes[1, 0]
    for i, e in enumerate(ELEMENTS):
        for a, v in result.fits[e].apparent.items():
            ax.plot(v["expected"], v["estimate"], "o", color=COLOURS[e],
                    label=e if a == result.fits[e].outputs[0] else None)
    lim = [-1.05, 1.05]
    ax.plot(lim, lim, "k:", lw=1)
    ax.set_xlabel("geometry coefficient M[n, c]")
    ax.set_ylabel("apparent coefficient")
    ax.set_title(f"geometry check (max dev {summary['geometry']['max_abs_deviation']:.3g})",
                 fontsize=9)
    ax.legend(fontsize=8)
    ax = axes[1, 1]
    for e in ELEMENTS:
        mis = result.fits[e].misfit
        ax.plot(range(len(mis)), list(mis.values()), "o-", color=COLOURS[e], label=e)
        ax.set_xticks(range(len(mis)), list(mis.keys()))
    ax.axhline(1.0, color="k", lw=0.8, ls=":")
    ax.set_title("misfit per output (about 1 when the model fits)", fontsize=9)
    ax.legend(fontsize=8)
    axes[1, 2].axis("off")
    return fig


def write_report(result, folder, paper="a4"):
    """Write the three PNG pages and ``uvw_report.pdf`` (landscape pages of
    ``paper``, "a4" or "letter") into ``folder``;
    returns their paths."""
    summary = result.summary()
    pages = [("uvw_elements.png", elements_page), ("uvw_xyz.png", xyz_page),
             ("uvw_agreement.png", agreement_page)]
    paths = []
    pdf_path = os.path.join(folder, "uvw_report.pdf")
    with PdfPages(pdf_path) as pdf:
        for name, make in pages:
            fig = make(result, summary, paper)
            path = os.path.join(folder, name)
            fig.savefig(path, dpi=110)
            save_pdf_page(pdf, fig, page_size(paper, landscape=True))
            plt.close(fig)
            paths.append(path)
    return paths + [pdf_path]
