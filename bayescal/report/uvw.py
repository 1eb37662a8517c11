"""Report pages of a UVW calibration, drawn from its folder alone:
``uvw.json`` and ``uvw_samples.npz`` (the arrays of
:func:`bayescal.coil.uvw.report_arrays`), in the style of every report
(:func:`bayescal.report.layout.style`: greys, line styles, a bold title
with its note at the top left).

Three pages, each a PNG and a page of ``uvw_report.pdf``:

* ``uvw_elements.png``: each element's response over the nominal (amplitude
  ratio and phase difference) with its 95 % credible band, and the table of
  the fitted parameters (median and 95 % interval);
* ``uvw_xyz.png``: the responses of the X, Y and Z outputs (the elements
  combined through the sensor's geometry) over the nominal, and the
  cross-talk between outputs against frequency, with 95 % bands;
* ``uvw_agreement.png``: Z-only and all-output estimates side by side
  (median, 68 % and 95 % intervals) and the geometry check (apparent against
  expected output coefficients).

Bands are equal-tailed pointwise intervals over posterior samples.
"""
from __future__ import annotations

import os

import numpy as np
from matplotlib.figure import Figure

from ..atomic import record_written
from ..coil.uvw import ELEMENTS, PARAMS, XYZ
from .layout import (GREYS, LINESTYLES, MARKERS, fit_columns, legend_beside, page_header,
                     page_size, sampler_line, style, write_pages)

#: Line style and grey of each element and output, one pair each.
STYLES = {name: (LINESTYLES[i % 3], GREYS[i % 3]) for i, name in enumerate(ELEMENTS + XYZ)}
LABELS = {"period_s": "period (s)", "damping": "damping", "gain": "gain"}
BAND = "95 % band"


def _band(ax, f, q, name, label):
    """A credible band and its median line from the quantiles ``q`` (3, F)."""
    lo, med, hi = q
    ls, grey = STYLES[name]
    ax.fill_between(f, lo, hi, color=grey, alpha=0.25, lw=0)
    ax.plot(f, med, color=grey, ls=ls, lw=1.2, label=label)


def _response_panels(fig, box, f, names, amp, phase, title):
    """Amplitude ratio and phase difference (deg) bands of ``names``
    (quantiles ``amp``, ``phase``: (len(names), 3, F)) in ``box`` (left,
    bottom, width, height as figure fractions)."""
    left, bottom, width, height = box
    a1 = fig.add_axes([left, bottom + 0.53 * height, width, 0.47 * height])
    a2 = fig.add_axes([left, bottom, width, 0.47 * height], sharex=a1)
    for name, qa, qp in zip(names, amp, phase):
        _band(a1, f, qa, name, f"{name} ({BAND})")
        _band(a2, f, qp, name, name)
    a1.set_xscale("log")
    a1.set_ylabel("amplitude / nominal")
    a2.set_ylabel("phase - nominal (deg)")
    a2.set_xlabel("frequency (Hz)")
    a1.tick_params(labelbottom=False)
    a1.set_title(title, loc="left")
    legend_beside(a1)


def _cell(entry):
    """A table cell: median (5 significant figures) and 95 % interval (4),
    or that the prior sets it (a value the prior sets is not a measurement)."""
    if not entry:
        return "-"
    if entry.get("set_by_prior"):
        return "set by the prior\n(not measured)"
    lo, hi = entry["ci95"]
    return f"{entry['median']:.5g}\n[{lo:.4g}, {hi:.4g}]"


def _head(fig, summary, title, note, paper):
    lines = [note, f"Mode: {summary['mode']}; gain in {summary['gain_units']}."]
    from ..core.posterior import not_converged_line
    for e, v in summary["elements"].items():
        lines.append(f"Element {e}: " + sampler_line(v["convergence"]).replace("Sampler: ", "sampler "))
        warn = not_converged_line(v["convergence"], what=f"the sampler of element {e}")
        if warn:
            lines.append(warn)
    page_header(fig, title, "\n".join(lines), page_size(paper, landscape=True)[0])


def elements_page(summary, arrays, paper="a4"):
    """Element responses over the nominal with 95 % bands, and the table."""
    fig = Figure(figsize=page_size(paper, landscape=True))
    _head(fig, summary, "UVW calibration: the elements",
          "Each element's response over its nominal, and its fitted parameters "
          "(median [95 % interval]).", paper)
    _response_panels(fig, (0.07, 0.08, 0.4, 0.62), arrays["freqs"], ELEMENTS,
                     arrays["element_amp"], arrays["element_phase"],
                     "Element responses over the nominal")
    ax = fig.add_axes([0.6, 0.3, 0.38, 0.4])
    ax.axis("off")
    cols = (*PARAMS, "damping_over_period")
    rows = [["", "period (s)", "damping", "gain", "damping/period (1/s)"]]
    rows += [[e] + [_cell(summary["elements"][e].get(p)) for p in cols] for e in ELEMENTS]
    rows, widths, _ = fit_columns(rows, 0.38 * fig.get_figwidth(), 6.5)
    tab = ax.table(cellText=rows[1:], colLabels=rows[0], loc="upper center", cellLoc="center",
                   bbox=[0, 0, 1, 1])
    tab.auto_set_font_size(False)
    tab.set_fontsize(6.5)
    for (i, j), cell in tab.get_celld().items():
        cell.set_width(widths[j])
        cell.set_height(1.0 if i == 0 else 2.0)
    ax.set_title("Fitted parameters: median [95 % interval]", loc="left")
    return fig


def xyz_page(summary, arrays, paper="a4"):
    """XYZ responses and cross-talk with 95 % bands."""
    fig = Figure(figsize=page_size(paper, landscape=True))
    _head(fig, summary, "UVW calibration: the X, Y and Z outputs",
          "Each output's response (the three elements combined through the sensor's geometry) "
          "over its nominal, and the cross-talk: how much of one output's motion another "
          "output records, in % of their own responses.", paper)
    _response_panels(fig, (0.07, 0.08, 0.36, 0.62), arrays["freqs"], XYZ, arrays["xyz_amp"],
                     arrays["xyz_phase"], "Output responses over the nominal")
    ax = fig.add_axes([0.62, 0.08, 0.25, 0.62])
    for (i, j), q in zip([(0, 1), (0, 2), (1, 2)], arrays["cross_talk_pairs"]):
        _band(ax, arrays["freqs"], q, XYZ[i + j - 1], f"{XYZ[i]}-{XYZ[j]} ({BAND})")
    ct = summary["cross_talk_max"]
    ax.set_xscale("log")
    ax.set_xlabel("frequency (Hz)")
    ax.set_ylabel("cross-talk (%)")
    ax.set_title(f"Cross-talk between outputs\nlargest cross-talk {100 * ct['median']:.3g} % "
                 f"[{100 * ct['ci95'][0]:.3g}, {100 * ct['ci95'][1]:.3g}] (95 %)", loc="left")
    legend_beside(ax)
    return fig


def _estimates_panel(ax, arrays, j, modes):
    """Median, 68 % and 95 % intervals of parameter ``j`` of each element,
    one row per element and estimate (``modes``: (label, array key))."""
    for k, (label, key) in enumerate(modes):
        for i, e in enumerate(ELEMENTS):
            q = np.percentile(arrays[f"{key}_{e}"][:, j], [2.5, 16, 50, 84, 97.5])
            y = i + 0.15 * (k - 0.5 * (len(modes) - 1))
            grey = GREYS[k]
            ax.plot([q[0], q[4]], [y, y], color=grey, lw=1)
            ax.plot([q[1], q[3]], [y, y], color=grey, lw=3)
            ax.plot(q[2], y, MARKERS[k], mfc="white", mec=grey, ms=4,
                    label=label if i == 0 else None)
    ax.set_yticks(range(3), ELEMENTS)
    ax.set_ylim(-0.6, 2.6)
    ax.locator_params(axis="x", nbins=4)


def agreement_page(summary, arrays, paper="a4"):
    """Z-only against all-output estimates, and the geometry check."""
    fig = Figure(figsize=page_size(paper, landscape=True))
    ag = summary.get("agreement")
    note = (ag["note"] + f" (largest |z| = {ag['max_abs_z']:.2f})" if ag else
            "Z-only comparison not available (Z-only mode, or no Z output).")
    _head(fig, summary, "UVW calibration: agreement and geometry", note, paper)
    axes = fig.subplots(2, 3, gridspec_kw={"left": 0.07, "right": 0.97, "bottom": 0.08,
                                           "top": 0.74, "hspace": 0.45, "wspace": 0.3})
    modes = [("all outputs" if summary["mode"] != "z-only" else "Z only", "element")]
    if all(f"z_only_{e}" in arrays for e in ELEMENTS):
        modes.append(("Z only", "z_only"))
    for j, p in enumerate(PARAMS):
        _estimates_panel(axes[0, j], arrays, j, modes)
        axes[0, j].set_title(LABELS[p] + (" (as fitted)" if p == "gain" else "")
                             + ": median, 68 and 95 %", loc="left")
    elements = summary["elements"]
    ax = axes[1, 0]
    for i, e in enumerate(ELEMENTS):
        for a, v in elements[e]["apparent_coefficient"].items():
            ax.plot(v["expected"], v["estimate"], MARKERS[i], mfc="white", mec=GREYS[i],
                    label=e if a == elements[e]["outputs_used"][0] else None)
    lim = [-1.05, 1.05]
    ax.plot(lim, lim, "k:", lw=1)
    ax.set_xlabel("geometry coefficient (expected)")
    ax.set_ylabel("apparent coefficient")
    ax.set_title(f"Geometry check (largest deviation "
                 f"{summary['geometry']['max_abs_deviation']:.3g})", loc="left")
    ax = axes[1, 1]
    for i, e in enumerate(ELEMENTS):
        mis = elements[e]["misfit"]
        ax.plot(range(len(mis)), list(mis.values()), color=GREYS[i], ls=LINESTYLES[i],
                marker=MARKERS[i], mfc="white", label=e)
        ax.set_xticks(range(len(mis)), list(mis.keys()))
    ax.axhline(1.0, color="k", lw=0.8, ls=":")
    ax.set_title("Misfit per output (about 1 when the model fits)", loc="left")
    key = axes[1, 2]                       # the keys of the panels, in the free panel
    key.axis("off")
    key.add_artist(key.legend(*axes[0, 0].get_legend_handles_labels(), loc="upper left",
                              title="estimates (top row)"))
    key.legend(*ax.get_legend_handles_labels(), loc="lower left", title="elements (bottom row)")
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
    with style():
        paths = write_pages(((os.path.join(folder, name), make(summary, arrays, paper))
                             for name, make in pages), pdf_path,
                            page=page_size(paper, landscape=True), dpi=110, grey=False)
    record_written(folder, [os.path.basename(p) for p in paths + [pdf_path]])
    return paths + [pdf_path]
