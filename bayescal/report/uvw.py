"""Report pages of a UVW calibration, drawn from its folder alone:
``uvw.json`` and ``uvw_samples.npz`` (the arrays of
:func:`bayescal.coil.uvw.report_arrays`).

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

from ..coil.uvw import ELEMENTS, PARAMS, XYZ  # noqa: E402
from .layout import page_size, write_pages  # noqa: E402

COLOURS = {"U": "tab:blue", "V": "tab:orange", "W": "tab:green",
           "X": "tab:red", "Y": "tab:purple", "Z": "tab:brown"}
LABELS = {"period_s": "period (s)", "damping": "damping", "gain": "gain"}


def _band(ax, f, q, colour, label):
    """A 90 % band and its median line from the quantiles ``q`` (3, F)."""
    lo, med, hi = q
    ax.fill_between(f, lo, hi, color=colour, alpha=0.3, lw=0)
    ax.plot(f, med, color=colour, lw=1.2, label=label)


def _response_panels(fig, f, names, amp, phase, title):
    """Amplitude ratio and phase difference (deg) bands of ``names``
    (quantiles ``amp``, ``phase``: (len(names), 3, F))."""
    a1, a2 = fig.subplots(2, 1, sharex=True)
    for name, qa, qp in zip(names, amp, phase):
        _band(a1, f, qa, COLOURS[name], name)
        _band(a2, f, qp, COLOURS[name], name)
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


def elements_page(summary, arrays, paper="a4"):
    """Element responses over the nominal with 90 % bands, and the table."""
    fig = plt.figure(figsize=page_size(paper, landscape=True))
    left, right = fig.subfigures(1, 2, width_ratios=[1.35, 1])
    _response_panels(left, arrays["freqs"], ELEMENTS, arrays["element_amp"],
                     arrays["element_phase"], "element responses (90 % bands)")
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


def xyz_page(summary, arrays, paper="a4"):
    """XYZ responses and cross-talk with 90 % bands."""
    fig = plt.figure(figsize=page_size(paper, landscape=True))
    left, right = fig.subfigures(1, 2)
    _response_panels(left, arrays["freqs"], XYZ, arrays["xyz_amp"], arrays["xyz_phase"],
                     "XYZ responses diag(M^T diag(k) M) (90 % bands)")
    ax = right.subplots()
    for (i, j), q, col in zip([(0, 1), (0, 2), (1, 2)], arrays["cross_talk_pairs"],
                              ["tab:cyan", "tab:olive", "tab:gray"]):
        _band(ax, arrays["freqs"], q, col, f"{XYZ[i]}-{XYZ[j]}")
    ct = summary["cross_talk_max"]
    ax.set_xscale("log")
    ax.set_xlabel("frequency (Hz)")
    ax.set_ylabel("cross-talk |T_lm| / sqrt(|T_ll T_mm|) (%)")
    ax.set_title(f"largest cross-talk {100 * ct['median']:.3g} % "
                 f"[{100 * ct['ci95'][0]:.3g}, {100 * ct['ci95'][1]:.3g}]", fontsize=9)
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=8)
    return fig


def agreement_page(summary, arrays, paper="a4"):
    """Z-only against all-output estimates, and the geometry check."""
    fig, axes = plt.subplots(2, 3, figsize=page_size(paper, landscape=True))
    modes = [("all outputs" if summary["mode"] != "z-only" else "Z only", "element")]
    if all(f"z_only_{e}" in arrays for e in ELEMENTS):
        modes.append(("Z only", "z_only"))
    for j, p in enumerate(PARAMS):
        ax = axes[0, j]
        for k, (label, key) in enumerate(modes):
            for i, e in enumerate(ELEMENTS):
                x = arrays[f"{key}_{e}"][:, j]
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
    elements = summary["elements"]
    for i, e in enumerate(ELEMENTS):
        for a, v in elements[e]["apparent_coefficient"].items():
            ax.plot(v["expected"], v["estimate"], "o", color=COLOURS[e],
                    label=e if a == elements[e]["outputs_used"][0] else None)
    lim = [-1.05, 1.05]
    ax.plot(lim, lim, "k:", lw=1)
    ax.set_xlabel("geometry coefficient M[n, c]")
    ax.set_ylabel("apparent coefficient")
    ax.set_title(f"geometry check (max dev {summary['geometry']['max_abs_deviation']:.3g})",
                 fontsize=9)
    ax.legend(fontsize=8)
    ax = axes[1, 1]
    for e in ELEMENTS:
        mis = elements[e]["misfit"]
        ax.plot(range(len(mis)), list(mis.values()), "o-", color=COLOURS[e], label=e)
        ax.set_xticks(range(len(mis)), list(mis.keys()))
    ax.axhline(1.0, color="k", lw=0.8, ls=":")
    ax.set_title("misfit per output (about 1 when the model fits)", fontsize=9)
    ax.legend(fontsize=8)
    axes[1, 2].axis("off")
    return fig


def write_report_from_folder(folder, paper="a4"):
    """Draw the three PNG pages and ``uvw_report.pdf`` (landscape pages of
    ``paper``, "a4" or "letter") of a ``bayescal uvw`` folder from its
    ``uvw.json`` and ``uvw_samples.npz`` alone, into the same folder;
    returns their paths."""
    import json

    with open(os.path.join(folder, "uvw.json")) as fh:
        summary = json.load(fh)
    with np.load(os.path.join(folder, "uvw_samples.npz")) as npz:
        arrays = {k: npz[k] for k in npz.files}
    pages = [("uvw_elements.png", elements_page), ("uvw_xyz.png", xyz_page),
             ("uvw_agreement.png", agreement_page)]
    pdf_path = os.path.join(folder, "uvw_report.pdf")
    paths = write_pages(((os.path.join(folder, name), make(summary, arrays, paper))
                         for name, make in pages), pdf_path,
                        page=page_size(paper, landscape=True), dpi=110, grey=False)
    return paths + [pdf_path]
