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

import corner
import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from .layout import CORNER_LEVELS, CORNER_QUANTILES, page_size  # noqa: E402


def timeseries_page(summary, arrays, paper="a4"):
    """Output, fitted model, input and standardised innovations."""
    model, resid, e = arrays["series_model"], arrays["series_residual"], arrays["innovations"]
    fs, skip = float(arrays["series_fs"]), int(arrays["series_skip"])
    t = np.arange(model.size) / fs
    data = model + resid
    fig, axes = plt.subplots(3, 1, figsize=page_size(paper, landscape=True),
                             gridspec_kw={"height_ratios": [2, 1, 1]})
    a1, a2, a3 = axes
    a1.plot(t, data, color="0.6", lw=0.6, label="recorded (offset, drift removed)")
    a1.plot(t, model, color="tab:blue", lw=1, label="fitted (posterior median)")
    if skip:
        a1.axvspan(0, skip / fs, color="0.9", label="settling time, not fitted")
    a1.set_ylabel("output (counts)")
    a1.legend(fontsize=8)
    a2.plot(t, resid, color="tab:red", lw=0.5)
    a2.set_ylabel("residual (counts)")
    a2.set_xlabel("time since record start (s)")
    a3.hist(e, bins=80, density=True, color="0.6")
    z = np.linspace(-4, 4, 200)
    a3.plot(z, np.exp(-z * z / 2) / np.sqrt(2 * np.pi), "k--", lw=1, label="unit normal")
    ad = summary["adequacy"]
    a3.set_xlabel(f"standardised innovation (AR({ad['ar_order']}) noise); mean square "
                  f"{ad['misfit']:.3f}, {ad['test']} p = {ad['p_value']:.3g}")
    a3.legend(fontsize=8)
    from ..core.posterior import not_converged_line
    warn = not_converged_line(summary["convergence"])
    fig.suptitle(f"{summary['channel']}: {summary['kind']} calibration, fit in time"
                 + (f"\n{warn}" if warn else ""), fontsize=10 if warn is None else 8)
    fig.tight_layout()
    return fig


def sine_corner_page(summary, arrays, paper="a4"):
    """Corner plot of the amplitude ratio and the phase difference."""
    data = arrays["corner_samples"]
    fig = plt.figure(figsize=(8, 8))
    corner.corner(data, fig=fig, labels=["amplitude / nominal", "phase - nominal (deg)"],
                  levels=CORNER_LEVELS, quantiles=CORNER_QUANTILES, plot_datapoints=False)
    fig.suptitle(f"{summary['channel']}: response at {summary['frequency_hz']:.5g} Hz "
                 "(2-D contours: 68 % and 95 % of the mass)")
    return fig
