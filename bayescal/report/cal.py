"""Report of a coil calibration of one channel, drawn from its folder alone:
``cal.json`` and ``cal_samples.npz`` (the arrays of
:meth:`bayescal.coil.result.CalFit.report_arrays`).

Three pages, each a PNG and a page of ``cal_report.pdf``:

* ``cal_response.png``: amplitude (counts per m/s) and phase of the measured
  response (per band, with 2-sigma error bars from the noise model), the
  fitted response (posterior median and pointwise equal-tailed 95 % band) and
  the nominal; below, the same as ratios to the nominal, where differences of
  a few per cent show;
* ``cal_residuals.png``: standardised band residuals (real and imaginary part)
  at the posterior median, and the convergence and adequacy numbers;
* ``cal_corner.png``: corner plot of the fitted parameters (2-D contours hold
  68 % and 95 % of the mass; 1-D lines at the 16, 50 and 84 % quantiles).
"""
from __future__ import annotations

import os

import corner
import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from .cal_time import sine_corner_page, timeseries_page  # noqa: E402
from .layout import CORNER_LEVELS, CORNER_QUANTILES, page_size, write_pages  # noqa: E402


def response_page(summary, arrays, paper="a4"):
    """Measured, fitted and nominal response; ratios to the nominal."""
    f, nom = arrays["curve_freqs"], arrays["curve_nominal"]
    amp, phase = arrays["curve_amp"], arrays["curve_phase"]
    if "measured_freqs" in arrays:
        fc, ratio_m, sd_m = arrays["measured_freqs"], arrays["measured_ratio"], arrays["measured_sd"]
        nom_c = arrays["measured_nominal"]
    else:                                       # time-domain fit: no per-band measurement
        fc, ratio_m, sd_m = np.zeros(0), np.zeros(0, complex), np.zeros(0)
        nom_c = np.zeros(0, complex)
    fig, axes = plt.subplots(2, 2, figsize=page_size(paper, landscape=True), sharex=True)
    (a_amp, a_ph), (r_amp, r_ph) = axes
    a_amp.loglog(f, np.abs(nom), "k--", lw=1, label="nominal")
    a_amp.fill_between(f, np.abs(nom) * amp[0], np.abs(nom) * amp[2], color="tab:blue",
                       alpha=0.3, lw=0)
    a_amp.plot(f, np.abs(nom) * amp[1], color="tab:blue", label="fitted (95 % band)")
    a_amp.errorbar(fc, np.abs(nom_c * ratio_m), yerr=2 * np.abs(nom_c) * sd_m, fmt=".",
                   color="tab:red", ms=3, label="measured (2 sigma)")
    a_amp.set_ylabel("amplitude (counts per m/s)")
    ph_nom = np.degrees(np.unwrap(np.angle(nom)))
    a_ph.plot(f, ph_nom, "k--", lw=1)
    a_ph.fill_between(f, ph_nom + phase[0], ph_nom + phase[2], color="tab:blue",
                      alpha=0.3, lw=0)
    a_ph.plot(f, ph_nom + phase[1], color="tab:blue")
    a_ph.plot(fc, np.interp(np.log(fc), np.log(f), ph_nom) + np.degrees(np.angle(ratio_m)), ".",
              color="tab:red", ms=3)
    a_ph.set_ylabel("phase (deg)")
    r_amp.fill_between(f, amp[0], amp[2], color="tab:blue", alpha=0.3, lw=0)
    r_amp.plot(f, amp[1], color="tab:blue")
    r_amp.errorbar(fc, np.abs(ratio_m), yerr=2 * sd_m, fmt=".", color="tab:red", ms=3)
    r_amp.axhline(1.0, color="k", ls="--", lw=1)
    r_amp.set_ylabel("amplitude / nominal")
    r_ph.fill_between(f, phase[0], phase[2], color="tab:blue", alpha=0.3, lw=0)
    r_ph.plot(f, phase[1], color="tab:blue")
    r_ph.errorbar(fc, np.degrees(np.angle(ratio_m)), yerr=np.degrees(2 * sd_m), fmt=".",
                  color="tab:red", ms=3)
    r_ph.axhline(0.0, color="k", ls="--", lw=1)
    r_ph.set_ylabel("phase - nominal (deg)")
    for a in axes.ravel():
        a.set_xscale("log")
        a.grid(True, which="both", alpha=0.3)
    for a in axes[1]:
        a.set_xlabel("frequency (Hz)")
    a_amp.legend(fontsize=8)
    fig.suptitle(f"{summary['channel']}: {summary['kind']} calibration, fit {summary['fit']}")
    return fig


def parameter_lines(summary):
    """The fitted values with 95 % intervals and nominal values; a value the
    prior sets is named as such, not printed as a measurement, and then
    the damping/period the data fix is given."""
    params = {k: v for k, v in summary["parameters"].items() if isinstance(v, dict)}
    nominal = dict(summary["nominal"])
    if nominal.get("period_s"):
        nominal["damping_over_period"] = nominal["damping"] / nominal["period_s"]
    flagged = [p for p in ("period_s", "damping") if params.get(p, {}).get("set_by_prior")]
    lines = []
    for p, e in params.items():
        if e.get("set_by_prior"):
            lines.append(f"{p}: SET BY THE PRIOR, not measured (nominal {nominal[p]:.6g}): "
                         f"{e['reason']}")
        elif p == "damping_over_period" and flagged:
            lines.append(f"the data fix damping/period = {e['median']:.4g} [{e['ci95'][0]:.4g}, "
                         f"{e['ci95'][1]:.4g}] 1/s (95 %), which the corrected StationXML's "
                         "poles carry")
        else:
            lines.append(f"{p}: {e['median']:.6g}  95 % [{e['ci95'][0]:.6g}, "
                         f"{e['ci95'][1]:.6g}]  (nominal {nominal.get(p, float('nan')):.6g})")
    return lines


def residuals_page(summary, arrays, paper="a4"):
    """Standardised band residuals at the median, convergence and adequacy."""
    from ..core.posterior import describe_sampler, not_converged_line

    z, fc = arrays["band_residual"], arrays["band_centres"]
    fig, (a1, a2) = plt.subplots(2, 1, figsize=page_size(paper, landscape=True),
                                 gridspec_kw={"height_ratios": [2, 1]})
    a1.semilogx(fc, z.real, "o", ms=4, label="real")
    a1.semilogx(fc, z.imag, "s", ms=4, label="imaginary")
    for y in (-2, 2):
        a1.axhline(y, color="k", ls=":", lw=1)
    a1.set_xlabel("frequency (Hz)")
    a1.set_ylabel("standardised band residual")
    a1.legend(fontsize=8)
    a1.grid(True, which="both", alpha=0.3)
    a2.axis("off")
    lines = ["Convergence: " + ", ".join(f"{k} {v:.4g}" if isinstance(v, float) else f"{k} {v}"
                                         for k, v in summary["convergence"].items()),
             "Adequacy: " + ", ".join(f"{k} {v:.4g}" if isinstance(v, float) else f"{k} {v}"
                                      for k, v in summary["adequacy"].items()),
             *([not_converged_line(summary["convergence"])]
               if not summary["convergence"].get("converged", True) else []),
             *([f"Sampler: {describe_sampler(summary['meta'].get('sampler'))}"]
               if summary.get("meta", {}).get("sampler") else []),
             f"Band {summary['band_hz'][0]:.4g}-{summary['band_hz'][1]:.4g} Hz; "
             f"fixed at nominal: {summary['fixed_at_nominal'] or 'nothing'}"]
    lines += parameter_lines(summary)
    for kind in ("hf_poles", "hf_zeros"):
        for e in summary["parameters"][kind]:
            lines.append(f"{kind[3:-1]} at {e['frequency_hz']:.4g} Hz: "
                         f"{e['real']['median']:.5g} + "
                         f"{e['imag'].get('median', 0.0):.5g}i rad/s "
                         f"(nominal {e['nominal'][0]:.5g} + {e['nominal'][1]:.5g}i)")
    a2.text(0.0, 1.0, "\n".join(lines), va="top", family="monospace", fontsize=8, wrap=True)
    fig.suptitle(f"{summary['channel']}: residuals, convergence, adequacy")
    return fig


def corner_page(summary, arrays, paper="a4"):
    """Corner plot of the fitted parameters in physical units."""
    data, labels = arrays["corner_samples"], [str(x) for x in arrays["corner_labels"]]
    fig = plt.figure(figsize=page_size(paper, landscape=True))
    corner.corner(data, fig=fig, labels=labels, levels=CORNER_LEVELS, quantiles=CORNER_QUANTILES,
                  plot_datapoints=False, label_kwargs={"fontsize": 8})
    fig.suptitle(f"{summary['channel']}: posterior (2-D contours: 68 % and 95 % of the mass)")
    return fig


#: The pages of each kind of run: (file name, page function).
PAGES = {"random": [("cal_response.png", response_page), ("cal_residuals.png", residuals_page),
                    ("cal_corner.png", corner_page)],
         "step": [("cal_response.png", response_page), ("cal_timeseries.png", timeseries_page),
                  ("cal_corner.png", corner_page)],
         "sine": [("cal_timeseries.png", timeseries_page), ("cal_corner.png", sine_corner_page)]}


def read_folder(folder):
    """``(summary, arrays)`` of one channel's calibration folder: ``cal.json``
    and the arrays of ``cal_samples.npz``."""
    import json

    with open(os.path.join(folder, "cal.json")) as fh:
        summary = json.load(fh)
    with np.load(os.path.join(folder, "cal_samples.npz")) as npz:
        arrays = {k: npz[k] for k in npz.files}
    return summary, arrays


def write_report(summary, arrays, folder, paper="a4"):
    """Write the PNG pages and ``cal_report.pdf`` (landscape pages of
    ``paper``, "a4" or "letter") into ``folder``: for a random run the three
    above; for a step run the response page (fitted and nominal only), the
    time series (:mod:`.cal_time`) and the corner plot; for a sine run the
    time series and the corner plot of amplitude and phase."""
    pdf_path = os.path.join(folder, "cal_report.pdf")
    paths = write_pages(((os.path.join(folder, name), make(summary, arrays, paper))
                         for name, make in PAGES[summary["kind"]]), pdf_path,
                        page=page_size(paper, landscape=True), dpi=100, grey=False)
    return paths + [pdf_path]


def write_report_from_folder(folder, paper="a4"):
    """Rebuild the report of a ``bayescal cal`` output folder from its files
    alone: the folder's own ``cal.json``, or (several output channels) each
    sub-folder's. Returns the paths written."""
    if os.path.isfile(os.path.join(folder, "cal.json")):
        return write_report(*read_folder(folder), folder, paper=paper)
    subs = sorted(d for d in os.listdir(folder)
                  if os.path.isfile(os.path.join(folder, d, "cal.json")))
    if not subs:
        from ..errors import InputError
        raise InputError(f"{folder}: no cal.json (not a bayescal cal folder)")
    return [p for d in subs for p in write_report_from_folder(os.path.join(folder, d), paper)]
