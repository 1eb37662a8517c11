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
import textwrap

import numpy as np
from matplotlib.figure import Figure

from ..atomic import record_written
from .cal_time import cal_head, sine_corner_page, timeseries_page
from .layout import (CORNER_LEVELS, CORNER_QUANTILES, GREYS, legend_beside, page_size, style,
                     write_pages)

#: How the pages draw the fitted, measured and nominal responses.
FITTED = {"color": "k", "lw": 1.1}
BAND = {"color": "0.6", "alpha": 0.35, "lw": 0}
MEASURED = {"fmt": "o", "color": GREYS[1], "mfc": "white", "ms": 3, "elinewidth": 0.8}
NOMINAL = {"color": "0.35", "ls": "--", "lw": 1.0}


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
    fig = Figure(figsize=page_size(paper, landscape=True))
    cal_head(fig, summary, f"{summary['kind']} calibration, fit {summary['fit']}",
          "Response of the channel (counts per m/s of ground velocity): fitted (posterior "
          "median, 95 % band), measured per band (2 sigma bars) and nominal (metadata); "
          "below, their ratio to the nominal.", paper)
    axes = fig.subplots(2, 2, sharex=True, gridspec_kw={"left": 0.08, "right": 0.8,
                                                        "bottom": 0.08, "top": 0.8,
                                                        "hspace": 0.12, "wspace": 0.25})
    (a_amp, a_ph), (r_amp, r_ph) = axes
    a_amp.loglog(f, np.abs(nom), label="nominal (metadata)", **NOMINAL)
    a_amp.fill_between(f, np.abs(nom) * amp[0], np.abs(nom) * amp[2], label="95 % band",
                       **BAND)
    a_amp.plot(f, np.abs(nom) * amp[1], label="fitted (posterior median)", **FITTED)
    a_amp.errorbar(fc, np.abs(nom_c * ratio_m), yerr=2 * np.abs(nom_c) * sd_m,
                   label="measured per band (2 sigma)", **MEASURED)
    a_amp.set_ylabel("amplitude (counts per m/s)")
    ph_nom = np.degrees(np.unwrap(np.angle(nom)))
    a_ph.plot(f, ph_nom, **NOMINAL)
    a_ph.fill_between(f, ph_nom + phase[0], ph_nom + phase[2], **BAND)
    a_ph.plot(f, ph_nom + phase[1], **FITTED)
    a_ph.errorbar(fc, np.interp(np.log(fc), np.log(f), ph_nom) + np.degrees(np.angle(ratio_m)),
                  yerr=np.degrees(2 * sd_m), **MEASURED)
    a_ph.set_ylabel("phase (deg)")
    r_amp.fill_between(f, amp[0], amp[2], **BAND)
    r_amp.plot(f, amp[1], **FITTED)
    r_amp.errorbar(fc, np.abs(ratio_m), yerr=2 * sd_m, **MEASURED)
    r_amp.axhline(1.0, **NOMINAL)
    r_amp.set_ylabel("amplitude / nominal")
    r_ph.fill_between(f, phase[0], phase[2], **BAND)
    r_ph.plot(f, phase[1], **FITTED)
    r_ph.errorbar(fc, np.degrees(np.angle(ratio_m)), yerr=np.degrees(2 * sd_m), **MEASURED)
    r_ph.axhline(0.0, **NOMINAL)
    r_ph.set_ylabel("phase - nominal (deg)")
    for a in axes.ravel():
        a.set_xscale("log")
    for a in axes[1]:
        a.set_xlabel("frequency (Hz)")
    legend_beside(a_ph, *a_amp.get_legend_handles_labels())
    return fig


#: Parameters of cal.json in words, with their units (a gain's from cal.json's ``units``).
NAMES = {"period_s": ("period", "s"), "damping": ("damping", ""),
         "damping_over_period": ("damping/period", "1/s")}


def _name_unit(summary, p):
    if p == "gain":
        return "gain", summary.get("units", {}).get("gain", "")
    return NAMES.get(p, (p, ""))


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
        name, unit = _name_unit(summary, p)
        unit = f" {unit}" if unit else ""
        if e.get("set_by_prior"):
            lines.append(f"{name}: SET BY THE PRIOR, not measured (nominal {nominal[p]:.6g}"
                         f"{unit}): {e['reason']}")
        elif p == "damping_over_period" and flagged:
            lines.append(f"the data fix damping/period = {e['median']:.4g} [{e['ci95'][0]:.4g}, "
                         f"{e['ci95'][1]:.4g}] 1/s (95 %), which the corrected StationXML's "
                         "poles carry")
        else:
            lines.append(f"{name}: {e['median']:.6g}  95 % [{e['ci95'][0]:.6g}, "
                         f"{e['ci95'][1]:.6g}]{unit}  (nominal "
                         f"{nominal.get(p, float('nan')):.6g})")
    return lines


def check_lines(summary):
    """The model check of a coil fit in words, from cal.json's ``adequacy``."""
    ad = summary["adequacy"]
    over = (f"{ad['n_bands']} bands" if "n_bands" in ad else f"{ad.get('n_samples')} samples")
    line = (f"Model check: misfit {ad['misfit']:.3g} over {over} (about 1 when the model "
            f"fits), p-value {ad['p_value']:.3g}")
    if ad.get("test"):
        line += f" ({ad['test']}; noise AR order {ad.get('ar_order')})"
    return [line]


def residuals_page(summary, arrays, paper="a4"):
    """Standardised band residuals at the median, convergence and adequacy."""
    from ..core.posterior import describe_sampler

    z, fc = arrays["band_residual"], arrays["band_centres"]
    fig = Figure(figsize=page_size(paper, landscape=True))
    cal_head(fig, summary, "residuals and the fitted values",
          "Standardised band residuals at the posterior median: about 95 % of them within "
          "+-2 when the model fits.", paper)
    a1 = fig.add_axes([0.08, 0.42, 0.72, 0.38])
    a1.semilogx(fc, z.real, "o", color="k", mfc="white", ms=4, label="real part")
    a1.semilogx(fc, z.imag, "s", color=GREYS[1], ms=4, label="imaginary part")
    for y in (-2, 2):
        a1.axhline(y, color="0.35", ls=":", lw=1)
    a1.set_xlabel("frequency (Hz)")
    a1.set_ylabel("standardised band residual (-)")
    legend_beside(a1)
    sampler = describe_sampler(summary.get("meta", {}).get("sampler"))
    lines = [*check_lines(summary),
             *([f"Sampler moves: {sampler}"] if sampler else []),
             f"Band {summary['band_hz'][0]:.4g}-{summary['band_hz'][1]:.4g} Hz; "
             f"held at nominal: {', '.join(summary['fixed_at_nominal']) or 'nothing'}", ""]
    lines += parameter_lines(summary)
    for kind in ("hf_poles", "hf_zeros"):
        for e in summary["parameters"][kind]:
            lines.append(f"{kind[3:-1]} at {e['frequency_hz']:.4g} Hz: "
                         f"{e['real']['median']:.5g} + "
                         f"{e['imag'].get('median', 0.0):.5g}i rad/s "
                         f"(nominal {e['nominal'][0]:.5g} + {e['nominal'][1]:.5g}i)")
    fig.text(0.08, 0.32, "\n".join(w for ln in lines for w in (textwrap.wrap(ln, 150) or [""])),
             va="top", fontsize=7.5, linespacing=1.4)
    return fig


def corner_page(summary, arrays, paper="a4"):
    """Corner plot of the fitted parameters in physical units."""
    import corner

    data, labels = arrays["corner_samples"], [str(x) for x in arrays["corner_labels"]]
    gain = summary.get("units", {}).get("gain", "").split(" (")[0]
    labels = [f"gain ({gain})" if lb == "gain" and gain else lb for lb in labels]
    fig = Figure(figsize=page_size(paper, landscape=True))
    corner.corner(data, fig=fig, labels=labels, levels=CORNER_LEVELS, quantiles=CORNER_QUANTILES,
                  color="k", plot_datapoints=False, plot_density=False, fill_contours=True,
                  contourf_kwargs={"colors": ["white", "0.88", "0.7"]}, smooth=1.0,
                  max_n_ticks=3, label_kwargs={"fontsize": 8})
    fig.subplots_adjust(left=0.3, right=0.7, bottom=0.1, top=0.8)
    cal_head(fig, summary, "posterior of the fitted parameters",
          "Contours hold 68 % and 95 % of the 2-D posterior mass; dashed lines on the 1-D "
          "histograms: 16, 50 and 84 % quantiles.", paper)
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
    with style():
        paths = write_pages(((os.path.join(folder, name), make(summary, arrays, paper))
                             for name, make in PAGES[summary["kind"]]), pdf_path,
                            page=page_size(paper, landscape=True), dpi=100, grey=False)
    record_written(folder, [os.path.basename(p) for p in paths + [pdf_path]])
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
