"""Report pages of a time-domain coil calibration (step or sine; see
:mod:`bayescal.coil.timedomain`), from the arrays saved with it
(:meth:`bayescal.coil.timedomain.TimeModel.report_series`):

* ``cal_timeseries.png``: the recorded output and the fitted model (posterior
  median, offset and drift removed) against time, the input below, and the
  standardised innovations (whitened residuals) with their histogram
  against the unit normal;
* for a sine run, ``cal_corner.png``: corner plot of the amplitude ratio and
  phase difference against the nominal (2-D contours at 68 % and 95 % of the
  mass).
"""
from __future__ import annotations

import numpy as np
from matplotlib.figure import Figure

from .layout import (CORNER_LEVELS, CORNER_QUANTILES, GREYS, legend_beside, page_header,
                     page_size, sampler_line)


def cal_head(fig, summary, title, note, paper):
    """A cal page's title and note (:func:`~.layout.page_header`), with the
    sampler's line and, when it did not converge, the warning."""
    from ..core.posterior import not_converged_line

    lines = [note, sampler_line(summary["convergence"])]
    warn = not_converged_line(summary["convergence"])
    if warn:
        lines.append(warn)
    page_header(fig, f"{summary['channel']}: {title}", "\n".join(lines),
                page_size(paper, landscape=True)[0])


def timeseries_page(summary, arrays, paper="a4"):
    """Output, fitted model, input and standardised innovations."""
    model, resid, e = arrays["series_model"], arrays["series_residual"], arrays["innovations"]
    fs, skip = float(arrays["series_fs"]), int(arrays["series_skip"])
    t = np.arange(model.size) / fs
    data = model + resid
    fig = Figure(figsize=page_size(paper, landscape=True))
    ad = summary["adequacy"]
    cal_head(fig, summary, f"{summary['kind']} calibration, fit in time",
          f"Model check: mean square of the standardised innovations {ad['misfit']:.3f} "
          f"(about 1 when the model fits), {ad['test']} p = {ad['p_value']:.3g}.", paper)
    a1, a2, a3 = fig.subplots(3, 1, gridspec_kw={"height_ratios": [2, 1, 1], "left": 0.08,
                                                 "right": 0.78, "bottom": 0.08, "top": 0.78,
                                                 "hspace": 0.5})
    a1.plot(t, data, color="0.6", lw=0.6, label="recorded (offset, drift removed)")
    a1.plot(t, model, color="k", lw=1, label="fitted (posterior median)")
    if skip:
        a1.axvspan(0, skip / fs, color="0.9", label="settling time, not fitted")
    a1.set_ylabel("output (counts)")
    a1.set_xlabel("time since record start (s)")
    legend_beside(a1)
    a2.plot(t, resid, color=GREYS[1], lw=0.5)
    a2.set_ylabel("residual (counts)")
    a2.set_xlabel("time since record start (s)")
    a3.hist(e, bins=80, density=True, color="0.7")
    z = np.linspace(-4, 4, 200)
    a3.plot(z, np.exp(-z * z / 2) / np.sqrt(2 * np.pi), "k--", lw=1, label="unit normal")
    a3.set_xlabel(f"standardised innovation (AR({ad['ar_order']}) noise)")
    a3.set_ylabel("density")
    legend_beside(a3)
    return fig


def sine_corner_page(summary, arrays, paper="a4"):
    """Corner plot of the amplitude ratio and the phase difference."""
    import corner

    fig = Figure(figsize=page_size(paper, landscape=True))
    corner.corner(arrays["corner_samples"], fig=fig,
                  labels=["amplitude / nominal", "phase - nominal (deg)"],
                  levels=CORNER_LEVELS, quantiles=CORNER_QUANTILES, color="k",
                  plot_datapoints=False, plot_density=False, fill_contours=True,
                  contourf_kwargs={"colors": ["white", "0.88", "0.7"]}, smooth=1.0,
                  max_n_ticks=3, label_kwargs={"fontsize": 8})
    fig.subplots_adjust(left=0.3, right=0.7, bottom=0.1, top=0.8)
    cal_head(fig, summary, f"response at {summary['frequency_hz']:.5g} Hz",
          "Contours hold 68 % and 95 % of the 2-D posterior mass; dashed lines on the 1-D "
          "histograms: 16, 50 and 84 % quantiles.", paper)
    return fig
