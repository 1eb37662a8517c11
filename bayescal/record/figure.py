"""The record's figure: each parameter's window estimates against time.

One panel per parameter (:class:`~bayescal.record.values.ParameterRecord`):
each window's median with its 95 % interval (dark) and its interval for the
record's value (light, wider by the wander), the record's value (line) and
its 95 % band (shaded), and the wander's smoothed path. Drawn in the
reports' style (:mod:`bayescal.report.layout`) and written as one PDF page
and one PNG.
"""
from __future__ import annotations

import numpy as np


def draw_parameter(ax, rec, legend=True):
    """One parameter's panel on axes ``ax`` (with the legend beside it)."""
    from ..report.layout import GREYS, legend_beside
    hours = rec.times / 3600.0
    lo, hi = rec.fit.mu["ci95"]
    ax.axhspan(lo, hi, color="0.85", lw=0, label="record value, 95 %")
    ax.axhline(rec.fit.mu["median"], color=GREYS[0], lw=1.0, label="record value")
    ax.errorbar(hours, rec.medians, yerr=np.abs(rec.record_ci95 - rec.medians[:, None]).T,
                fmt="none", ecolor="0.7", elinewidth=2.5, label="window: record's value, 95 %")
    ax.errorbar(hours, rec.medians, yerr=np.abs(rec.ci95 - rec.medians[:, None]).T, fmt="o",
                ms=2.5, color=GREYS[0], ecolor=GREYS[1], elinewidth=0.8,
                label="window: median, 95 %")
    ax.plot(hours, rec.fit.path, ls="--", color=GREYS[3], lw=1.0, label="wander, smoothed")
    tau = rec.fit.tau
    ax.set_title(f"{rec.name}: {rec.fit.mu['median']:.4g} [{lo:.4g}, {hi:.4g}]; wander sd "
                 f"{tau['median']:.2g} [{tau['ci95'][0]:.2g}, {tau['ci95'][1]:.2g}], time "
                 f"scale {rec.fit.ell['median'] / 3600:.2g} h", loc="left")
    ax.set_xlabel(f"hours after {str(rec.starts[0])[:19]}")
    if legend:
        legend_beside(ax)


def build_figure(records):
    """The figure of ``records`` (name -> ParameterRecord), one panel each."""
    import matplotlib.pyplot as plt
    n = len(records)
    fig, axes = plt.subplots(n, 1, figsize=(10.0, 1.2 + 2.2 * n), squeeze=False)
    for k, (ax, rec) in enumerate(zip(axes[:, 0], records.values())):
        draw_parameter(ax, rec, legend=k == 0)
    fig.subplots_adjust(left=0.08, right=0.7, top=1 - 0.4 / fig.get_figheight(),
                        bottom=0.5 / fig.get_figheight(), hspace=0.7)
    return fig


def write_figure(records, folder):
    """Write ``folder``/windows.pdf and windows.png of ``records``."""
    import os

    from ..report.layout import style, write_pages
    with style():
        fig = build_figure(records)
        write_pages([(os.path.join(folder, "windows.png"), fig)],
                    os.path.join(folder, "windows.pdf"), grey=False)
