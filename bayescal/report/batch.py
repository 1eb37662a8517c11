"""Tables and the summary report of a batch run.

``results.csv`` has one row per item and SUT channel (one row with only the
``error`` column filled for a failed item). Angles are SEED degrees; bounds
are the 95 % equal-tailed credible interval.

Flags (``flags.csv`` and the report), per station, channel and quantity
(azimuth, dip, gain):

* ``off_nominal``: the estimate differs from the StationXML value by more
  than the threshold AND the 95 % interval excludes the nominal value
  (:func:`bayescal.report.flags.off_nominal`, the rule of ``bayescal
  report`` too);
* ``changed``: between two consecutive results of the same pair (the same
  SUT channel against the same reference channels, column
  ``reference_channels``; results in order of day, then label), the
  estimate moved by more than the threshold AND by more than the combined
  95 % half-widths ``sqrt(h1**2 + h2**2)`` (the change is beyond the
  uncertainty). The flag is put on the later result. Two pairs of one
  station on one day are two series, never compared with each other.

Angle thresholds are in degrees (default :data:`FLAG_THRESHOLD_DEG`, the
default of ``bayescal report`` too), the gain threshold in percent (default
:data:`FLAG_THRESHOLD_PCT`). The rules are in :mod:`bayescal.report.flags`.
"""
from __future__ import annotations

import csv
import datetime
import json
import os
import textwrap
from functools import partial

import numpy as np

from ..atomic import atomic_path
from ..criticism.words import LAPLACE, posterior_text
from .flags import (FLAG_COLUMNS, FLAG_THRESHOLD_DEG, FLAG_THRESHOLD_PCT, deviation_series,
                    find_flags, wrap_deg)


COLUMNS = ("label", "station", "day", "channel", "reference_channels", "kind",
           "azimuth", "azimuth_lo95", "azimuth_hi95", "nominal_azimuth",
           "dip", "dip_lo95", "dip_hi95", "nominal_dip",
           "tilt", "tilt_lo95", "tilt_hi95",
           "gain", "gain_lo95", "gain_hi95", "nominal_gain",
           "ess_min", "tau_max", "rhat_max", "converged", "effects", "effects_not_heading",
           "notes", "error")
#: results.csv's columns that hold text (the others are numbers).
TEXT_COLUMNS = ("label", "station", "day", "channel", "reference_channels", "kind", "effects",
                "effects_not_heading", "notes", "error", "converged")


def _interval(entry):
    """(median, lo95, hi95) of a summary entry; bounds None if fixed/undefined."""
    if not entry or entry.get("undefined"):
        return None, None, None
    ci = entry.get("ci95")
    return entry["median"], (ci[0] if ci else None), (ci[1] if ci else None)


def _rows_for(item, folder):
    with open(os.path.join(folder, "result.json")) as fh:
        res = json.load(fh)
    conv = res.get("convergence", {})
    if posterior_text(res):        # the improved model's Laplace approximation: no chain
        conv = {"converged": conv.get("converged")}
    day = item.get("day") or str(res.get("meta", {}).get("starttime", ""))[:10]
    effects, not_heading = _effects(res.get("meta", {}))
    notes = _notes(res.get("meta", {}))
    refs = ";".join(sorted(res.get("meta", {}).get("reference") or {}))
    rows = []
    for cid, ch in res["channels"].items():
        nom = ch.get("nominal", {})
        az, az_lo, az_hi = _interval(ch.get("azimuth_deg"))
        dip, dip_lo, dip_hi = _interval(ch.get("dip_deg"))
        tilt, t_lo, t_hi = _interval(ch.get("tilt_deg"))
        gain, g_lo, g_hi = _interval(ch.get("response", {}).get("gain"))
        rows.append({"label": item["label"], "station": ".".join(cid.split(".")[:2]), "day": day,
                     "channel": cid, "reference_channels": refs, "kind": ch.get("kind"),
                     "azimuth": az,
                     "azimuth_lo95": az_lo, "azimuth_hi95": az_hi,
                     "nominal_azimuth": None if az is None else nom.get("azimuth_deg"),
                     "dip": dip, "dip_lo95": dip_lo, "dip_hi95": dip_hi,
                     "nominal_dip": nom.get("dip_deg"), "tilt": tilt, "tilt_lo95": t_lo,
                     "tilt_hi95": t_hi, "gain": gain, "gain_lo95": g_lo, "gain_hi95": g_hi,
                     "nominal_gain": None if gain is None else nom.get("gain"),
                     "ess_min": conv.get("ess_min"), "tau_max": conv.get("tau_max"),
                     "rhat_max": conv.get("rhat_max"), "converged": conv.get("converged"),
                     "effects": effects, "effects_not_heading": not_heading, "notes": notes,
                     "error": ""})
    return rows


def _effects(meta):
    """The ``effects`` and ``effects_not_heading`` columns (";"-joined):
    the effects the headline's model holds (``meta.headline``: the improved
    model's, the reference's noise included; none for a fit that misfits),
    and those the criticism named that it leaves out."""
    head = meta.get("headline") or {}
    held = list(head.get("effects", [])) + (["reference_noise"] if head.get("reference_noise")
                                            else [])
    return ";".join(map(str, held)), ";".join(map(str, head.get("not_heading", [])))


def _notes(meta):
    """The fit's cautions in a few words for the ``notes`` column (the full
    sentences are in the item's result.json): estimates under the
    criticism's improved model, a short record, a reference noise poorly
    separated from the ground motion."""
    out = []
    head = meta.get("headline") or {}
    if head.get("model") == "improved":
        out.append(f"estimates under the improved model ({head.get('label') or 'its effects'})")
    if posterior_text({"meta": meta}):
        out.append(LAPLACE)
    rl = meta.get("record_length", {})
    if rl.get("note"):
        out.append(f"short record ({rl['periods_of_lower_edge']:.1f} periods of "
                   f"{rl['lower_edge_hz']:.3g} Hz)")
    if meta.get("reference_noise", {}).get("separation", {}).get("note"):
        out.append("reference noise poorly separated")
    return ";".join(out)


def results_table(items, out):
    """Read every item's folder and write ``out/results.csv``; returns its path."""
    rows = []
    for item in items:
        folder = os.path.join(out, item["label"])
        station = f"{item['network']}.{item['station']}" if "station" in item else ""
        failed = {"label": item["label"], "station": station, "day": item.get("day", "")}
        if os.path.isfile(os.path.join(folder, "result.json")):
            rows.extend(_rows_for(item, folder))
        elif os.path.isfile(os.path.join(folder, "error.json")):
            with open(os.path.join(folder, "error.json")) as fh:
                rows.append({**failed, "error": json.load(fh)["error"]})
        else:
            rows.append({**failed, "error": "not run"})
    path = os.path.join(out, "results.csv")
    _write_csv(path, COLUMNS, rows)
    return path


def _write_csv(path, columns, rows):
    with atomic_path(path) as tmp, open(tmp, "w", newline="") as fh:
        w = csv.DictWriter(fh, fieldnames=columns, extrasaction="ignore")
        w.writeheader()
        for r in rows:
            w.writerow({k: ("" if r.get(k) is None else r.get(k, "")) for k in columns})


def read_results(path):
    """``results.csv`` as a list of dicts with numbers converted."""
    with open(path, newline="") as fh:
        rows = list(csv.DictReader(fh))
    for r in rows:
        for k, v in r.items():
            if k not in TEXT_COLUMNS:
                r[k] = float(v) if v != "" else None
    return rows


def _date(day):
    return datetime.date.fromisoformat(day)


def date_ticks(days, most=8):
    """Tick positions of a time axis: distinct dates of ``days`` (ISO
    strings), every k-th when there are more than ``most``, so that no date
    is written twice."""
    dates = sorted({_date(d) for d in days})
    step = -(-len(dates) // most)
    return dates[::step]


def _short(refs):
    """Reference channels (``;``-joined SEED ids) as location.channel codes."""
    return ",".join(".".join(r.split(".")[2:]) for r in refs.split(";") if r) or "?"


def _pair_label(cid, refs, several):
    """A curve's legend: the SUT channel code, and the reference channels'
    location.channel codes when a station has several pairs."""
    code = cid.split(".")[-1]
    return f"{code} vs {_short(refs)}" if several else code


def _pair_styles(rows, sta):
    """Line style of each pair of station ``sta`` (same in every panel):
    ``{(channel, reference_channels): {color, ls, marker}}``, in the
    report's greys, line styles and markers."""
    from .layout import GREYS, LINESTYLES, MARKERS

    pairs = sorted({(r["channel"], r.get("reference_channels") or "") for r in rows
                    if r.get("station") == sta and not r.get("error")})
    return {p: {"color": GREYS[k % len(GREYS)], "ls": LINESTYLES[k % len(LINESTYLES)],
                "marker": MARKERS[k % len(MARKERS)]} for k, p in enumerate(pairs)}


def _station_panel(ax, rows, flags, sta, quantity, styles):
    """One station's curves of ``quantity`` (one per pair, styled by
    ``styles``) on ``ax``: medians with their 95 % intervals, a cross on each
    flagged result and a dashed line on each day a pair's result changed."""
    series = {k: v for k, v in sorted(deviation_series(rows, quantity).items()) if k[0] == sta}
    flagged = {(f["channel"], f["reference_channels"], f["quantity"], f["label"]) for f in flags}
    for (_, cid, refs), points in series.items():
        st = styles[(cid, refs)]
        days = [_date(p[0]) for p in points]
        dev, lo, hi = (np.array([p[k] for p in points]) for k in (2, 3, 4))
        ax.errorbar(days, dev, yerr=[dev - lo, hi - dev], color=st["color"], ls=st["ls"],
                    marker=st["marker"], ms=3.5, mfc="white", lw=0.9, elinewidth=0.8,
                    capsize=2)
        bad = [(d, v) for d, v, p in zip(days, dev, points)
               if (cid, refs, quantity, p[1]) in flagged]
        if bad:
            ax.plot(*zip(*bad), "x", color="k", ms=9, mew=1.5)
    for day in sorted({f["day"] for f in flags if f["station"] == sta
                       and f["quantity"] == quantity and f["flag"] == "changed"}):
        ax.axvline(_date(day), color="k", ls="--", lw=0.8)


def _legend(ax, styles):
    """The station's legend beside ``ax`` (the row's last panel): one entry
    per pair."""
    from matplotlib.lines import Line2D

    from .layout import legend_beside

    several = len({refs for _, refs in styles}) > 1
    legend_beside(ax, handles=[Line2D([], [], mfc="white", ms=3.5,
                                      label=_pair_label(cid, refs, several), **st)
                               for (cid, refs), st in styles.items()])


def _key(fig, page):
    """The page's key of the marks (flags, changes, thresholds), at the top
    right, beside the page's note."""
    from matplotlib.lines import Line2D

    fig.legend(handles=[Line2D([], [], ls="none", marker="x", color="k", ms=7, mew=1.5,
                               label="flagged result"),
                        Line2D([], [], color="k", ls="--", lw=0.8, label="changed"),
                        Line2D([], [], color="0.5", ls=":", lw=0.8, label="threshold")],
               loc="upper right", bbox_to_anchor=(0.98, 1 - 0.4 / page[1]), borderaxespad=0.0)


def _time_axis(fig, axes, rows, stations):
    """Dates on the bottom row's x axes, each date once, tilted."""
    import matplotlib.dates as mdates
    from matplotlib.artist import setp

    days = [r["day"] for r in rows if r.get("station") in stations and not r.get("error")
            and r.get("day")]
    if not days:
        return
    first, last = (datetime.datetime.combine(_date(d), datetime.time())
                   for d in (min(days), max(days)))
    half = datetime.timedelta(hours=12)
    for ax in axes[-1]:
        ax.set_xticks(date_ticks(days))
        ax.xaxis.set_major_formatter(mdates.DateFormatter("%Y-%m-%d"))
        ax.set_xlim(first - half, last + half)
        ax.set_xlabel("day")
        setp(ax.get_xticklabels(), rotation=30, horizontalalignment="right")


def _time_note(quantities, threshold_deg, gain_threshold_pct):
    gain = ", gain in % of nominal" if "gain" in quantities else ""
    return (f"Each result's deviation from its StationXML nominal value (azimuth and dip in "
            f"degrees{gain}): median and 95 % credible interval, one curve per pair (the SUT "
            "channel against its reference channels), against the day recorded. A result is "
            f"flagged beyond the threshold (+-{threshold_deg:g} deg"
            + (f", +-{gain_threshold_pct:g} %" if gain else "") + ") and beyond its 95 % "
            "interval; a dashed line marks the day a pair's result changed from its result "
            "before.")


def _figure(rows, flags, stations, threshold_deg, gain_threshold_pct, page):
    """A page of the results of ``stations`` against time: one row of
    panels per station (azimuth, dip, and gain when fitted), the station's
    legend beside its row."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    from .layout import page_header, text_extent

    quantities = ("azimuth", "dip") + (("gain",) if deviation_series(rows, "gain") else ())
    fig = Figure(figsize=page)
    FigureCanvasAgg(fig)
    page_header(fig, "bayescal batch report: orientation" + (" and gain" if "gain" in quantities
                                                            else "") + " against time",
                _time_note(quantities, threshold_deg, gain_threshold_pct), 0.75 * page[0])
    _key(fig, page)
    top = text_extent(fig, fig.texts[-1])[1] - 0.3 / page[1]        # below the note
    bottom = 0.75 / page[1]
    axes = fig.subplots(len(stations), len(quantities), squeeze=False, sharex=True)
    fig.subplots_adjust(left=0.09, right=0.79, top=top, wspace=0.5, hspace=0.35,
                        bottom=top - (top - bottom) * len(stations) / max(len(stations), 3))
    for row, sta in zip(axes, stations):
        styles = _pair_styles(rows, sta)
        for ax, quantity in zip(row, quantities):
            _station_panel(ax, rows, flags, sta, quantity, styles)
            thr, unit = (gain_threshold_pct, "%") if quantity == "gain" else (threshold_deg, "deg")
            for y in (-thr, thr):
                ax.axhline(y, color="0.5", ls=":", lw=0.8)
            ax.axhline(0, color="k", lw=0.6)
            ax.set_ylabel(f"deviation ({unit})")
            ax.set_title(f"{sta}: {quantity}", loc="left")
        _legend(row[-1], styles)
    _time_axis(fig, axes, rows, stations)
    return fig


def _count(n, noun):
    return f"{n} {noun}{'' if n == 1 else 's'}"


def summary_lines(rows, flags, threshold_deg, gain_threshold_pct):
    """The summary page's sentences: what ran, convergence, the flag rule."""
    labels = sorted({r["label"] for r in rows})
    failed = sorted({r["label"] for r in rows if r.get("error")})
    ok = [r for r in rows if not r.get("error")]
    chains = [r for r in ok if r["ess_min"] is not None]      # a Laplace approximation has none
    not_converged = sorted({r["label"] for r in ok if r["converged"] != "True"})
    lines = [f"{_count(len(labels), 'item')}: {len(labels) - len(failed)} calibrated, "
             f"{len(failed)} failed; {_count(len({r['station'] for r in ok}), 'station')}, "
             f"{_count(len({r['day'] for r in ok}), 'day')}"]
    if chains:
        lines.append(f"Sampler, over the items: min ESS {min(r['ess_min'] for r in chains):.0f}, "
                     f"max R-hat {max(r['rhat_max'] for r in chains):.4f} (effective sample "
                     "size, Gelman-Rubin statistic); "
                     + ("every item converged" if not not_converged else
                        f"not converged: {', '.join(not_converged)}"))
    elif ok:
        lines.append("Posterior: no item has a sampler chain (Laplace approximations)")
    lines += [f"Flags: beyond {threshold_deg:g} deg (azimuth, dip) or {gain_threshold_pct:g} % "
              "(gain) AND beyond the 95 % uncertainty; off nominal against the StationXML, "
              "changed against the same pair's result before",
              f"Flagged: {len(flags)} in {_count(len({f['station'] for f in flags}), 'station')}"
              " (all in flags.csv)"]
    return lines




#: The result.json entry (keys from a channel's) of each quantity of results.csv.
ENTRIES = {"azimuth": ("azimuth_deg",), "dip": ("dip_deg",), "gain": ("response", "gain")}


def _ci68(folder, label, cid, quantity):
    """The 68 % interval of a result from its item's ``folder/label/result.json``;
    None when the file or the entry is not there."""
    try:
        with open(os.path.join(folder, label, "result.json")) as fh:
            entry = json.load(fh)["channels"][cid]
        for key in ENTRIES[quantity]:
            entry = entry[key]
        return list(entry["ci68"])
    except (OSError, ValueError, KeyError, TypeError):
        return None


def _flag_row(flag, result, folder):
    """A flag as a line of the summary table
    (:func:`~bayescal.report.layout.summary_table`): the flagged result
    (``result``, its row of results.csv; its 68 % interval from its item's
    result.json in ``folder``), its nominal value and deviation, and the
    flag in the note."""
    from .tables import Row

    q = flag["quantity"]
    val, nom = result[q], result[f"nominal_{q}"]
    dev = 100.0 * (val / nom - 1.0) if q == "gain" else (
        wrap_deg(val - nom) if q == "azimuth" else val - nom)
    note = (f"off nominal on {flag['day']}" if flag["flag"] == "off_nominal" else
            f"changed by {flag['value']:+.2f} {flag['unit']} [{flag['lo95']:+.2f}, "
            f"{flag['hi95']:+.2f}] from {flag['previous_day']} to {flag['day']}")
    refs = flag["reference_channels"]
    return Row(flag["channel"] + (f"\nvs {_short(refs)}" if refs else ""), q, val,
               _ci68(folder, flag["label"], flag["channel"], q),
               [result[f"{q}_lo95"], result[f"{q}_hi95"]], nom, dev, note)


def _failed_lines(rows, most):
    """The summary page's lines on the failed items and on how to read the table."""
    errors = sorted({(r["label"], r["error"]) for r in rows if r.get("error")})
    lines = [f"Failed items: {len(errors) or 'none'}"
             + (f" (the first {most}; all in results.csv)" if len(errors) > most else "")]
    for label, err in errors[:most]:
        lines += textwrap.wrap(f"{label}: {err}", 100, initial_indent="  ",
                               subsequent_indent="    ")
    return lines + [""] + textwrap.wrap(
        "Deviation: estimate - StationXML nominal (gain: in % of nominal). The table's 95 % "
        "intervals are those of results.csv, its 68 % intervals those of each item's result.json "
        "('-' where the item's folder holds none).", 100)


def _continued(page):
    """A continuation page of the summary page; returns (figure, top)."""
    from matplotlib.figure import Figure

    fig = Figure(figsize=page)
    fig.text(0.06, 0.965, "bayescal batch report (page 1 continued)", fontsize=14,
             fontweight="bold")
    return fig, 0.94


def _summary_pages(rows, flags, threshold_deg, gain_threshold_pct, page, folder, most=25):
    """The summary page (and its continuations): what ran in sentences,
    the flags in the fit report's table (68 % intervals from the items'
    result.json files in ``folder``), the failed items."""
    from matplotlib.figure import Figure

    from .layout import flow_text, summary_table, text_extent

    fig = Figure(figsize=page)
    fig.text(0.06, 0.965, "bayescal batch report", fontsize=14, fontweight="bold")
    lines = summary_lines(rows, flags, threshold_deg, gain_threshold_pct)
    art = fig.text(0.06, 0.945, "\n".join(textwrap.fill(t, 110) for t in lines), va="top",
                   fontsize=8, linespacing=1.5)
    top = text_extent(fig, art)[1] - 0.02
    if flags:
        by_item = {(r["label"], r["channel"]): r for r in rows if not r.get("error")}
        more = f", the first {most} of {len(flags)}; all in flags.csv" if len(flags) > most else ""
        top = summary_table(fig, top, [_flag_row(f, by_item[(f["label"], f["channel"])], folder)
                                       for f in flags[:most]],
                            f"Flags: the flagged results{more}", False)
    return flow_text(fig, 0.06, top, _failed_lines(rows, most), partial(_continued, page),
                     fontsize=8, linespacing=1.5)


def write_report(results_csv, out, threshold_deg=FLAG_THRESHOLD_DEG,
                 gain_threshold_pct=FLAG_THRESHOLD_PCT, per_page=6, paper="a4"):
    """``flags.csv``, ``report.pdf`` (summary page + orientation pages, every
    page of ``paper``, "a4" or "letter") and ``report.png`` (first
    orientation page) in ``out``; returns their paths and the flags."""
    from .layout import page_size, style, write_pages

    rows = read_results(results_csv)
    flags = find_flags(rows, threshold_deg, gain_threshold_pct)
    paths = {"flags": os.path.join(out, "flags.csv"), "pdf": os.path.join(out, "report.pdf"),
             "png": os.path.join(out, "report.png")}
    _write_csv(paths["flags"], FLAG_COLUMNS, flags)
    stations = sorted({r["station"] for r in rows if r.get("station") and not r.get("error")})
    groups = [stations[k:k + per_page] for k in range(0, len(stations), per_page)]
    page = page_size(paper)

    def pages():
        for fig in _summary_pages(rows, flags, threshold_deg, gain_threshold_pct, page,
                                  os.path.dirname(os.path.abspath(results_csv))):
            yield None, fig
        for k, stas in enumerate(groups):
            yield (paths["png"] if k == 0 else None), _figure(rows, flags, stas, threshold_deg,
                                                              gain_threshold_pct, page)
    with style():
        write_pages(pages(), paths["pdf"], page=page)
    return {**paths, "flag_list": flags}
