"""Tables and the summary report of a batch run.

``results.csv`` has one row per item and SUT channel (one row with only the
``error`` column filled for a failed item). Angles are SEED degrees; bounds
are the 95 % equal-tailed credible interval.

Flags (``flags.csv`` and the report), per station, channel and quantity
(azimuth, dip, gain):

* ``off_nominal``: the estimate differs from the StationXML value by more
  than the threshold AND the 95 % interval excludes the nominal value;
* ``changed``: between two consecutive days with results, the estimate moved
  by more than the threshold AND by more than the combined 95 % half-widths
  ``sqrt(h1**2 + h2**2)`` (the change is beyond the uncertainty). The flag is
  put on the later day.

Angle thresholds are in degrees, the gain threshold in percent.
"""
from __future__ import annotations

import csv
import datetime
import json
import os

import numpy as np

from ..atomic import atomic_path
from ..criticism.words import LAPLACE, posterior_text
from .layout import page_size, write_pages

COLUMNS = ("label", "station", "day", "channel", "kind",
           "azimuth", "azimuth_lo95", "azimuth_hi95", "nominal_azimuth",
           "dip", "dip_lo95", "dip_hi95", "nominal_dip",
           "tilt", "tilt_lo95", "tilt_hi95",
           "gain", "gain_lo95", "gain_hi95", "nominal_gain",
           "ess_min", "tau_max", "rhat_max", "converged", "effects", "effects_not_heading",
           "notes", "error")
FLAG_COLUMNS = ("station", "channel", "quantity", "flag", "day", "previous_day", "value",
                "lo95", "hi95", "reference", "threshold", "unit")


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
    rows = []
    for cid, ch in res["channels"].items():
        nom = ch.get("nominal", {})
        az, az_lo, az_hi = _interval(ch.get("azimuth_deg"))
        dip, dip_lo, dip_hi = _interval(ch.get("dip_deg"))
        tilt, t_lo, t_hi = _interval(ch.get("tilt_deg"))
        gain, g_lo, g_hi = _interval(ch.get("response", {}).get("gain"))
        rows.append({"label": item["label"], "station": ".".join(cid.split(".")[:2]), "day": day,
                     "channel": cid, "kind": ch.get("kind"), "azimuth": az,
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
            if k not in ("label", "station", "day", "channel", "kind", "effects",
                         "effects_not_heading", "notes", "error", "converged"):
                r[k] = float(v) if v != "" else None
    return rows


def _wrap(d):
    return (d + 180.0) % 360.0 - 180.0


def _series(rows, quantity):
    """Per (station, channel): sorted list of (day, dev, lo, hi, nominal) of
    the deviation from nominal (degrees, or percent for the gain)."""
    out = {}
    for r in rows:
        val, nom = r.get(quantity), r.get(f"nominal_{quantity}")
        if r.get("error") or val is None or nom is None or r.get(f"{quantity}_lo95") is None:
            continue
        lo, hi = r[f"{quantity}_lo95"], r[f"{quantity}_hi95"]
        if quantity == "gain":
            dev, dlo, dhi = (100.0 * (x / nom - 1.0) for x in (val, lo, hi))
        else:
            dev = _wrap(val - nom) if quantity == "azimuth" else val - nom
            dlo, dhi = dev - (val - lo), dev + (hi - val)
        out.setdefault((r["station"], r["channel"]), []).append((r["day"], dev, dlo, dhi, nom))
    return {k: sorted(v) for k, v in out.items()}


def find_flags(rows, threshold_deg=2.0, gain_threshold_pct=2.0):
    """Flags (list of dicts, columns :data:`FLAG_COLUMNS`) from results rows."""
    flags = []
    for quantity, thr, unit in (("azimuth", threshold_deg, "deg"), ("dip", threshold_deg, "deg"),
                                ("gain", gain_threshold_pct, "%")):
        for (sta, cid), series in sorted(_series(rows, quantity).items()):
            base = {"station": sta, "channel": cid, "quantity": quantity, "threshold": thr,
                    "unit": unit}
            for day, dev, lo, hi, nom in series:
                if abs(dev) > thr and not lo <= 0.0 <= hi:
                    flags.append({**base, "flag": "off_nominal", "day": day, "previous_day": "",
                                  "value": dev, "lo95": lo, "hi95": hi, "reference": nom})
            for (d0, v0, lo0, hi0, _), (d1, v1, lo1, hi1, _) in zip(series, series[1:]):
                delta = _wrap(v1 - v0) if quantity == "azimuth" else v1 - v0
                combined = np.hypot((hi0 - lo0) / 2, (hi1 - lo1) / 2)
                if abs(delta) > thr and abs(delta) > combined:
                    flags.append({**base, "flag": "changed", "day": d1, "previous_day": d0,
                                  "value": delta, "lo95": delta - combined,
                                  "hi95": delta + combined, "reference": v0})
    return flags


def _date(day):
    return datetime.date.fromisoformat(day)


def _figure(rows, flags, stations, threshold_deg, gain_threshold_pct, page):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    quantities = ("azimuth", "dip") + (("gain",) if _series(rows, "gain") else ())
    fig, axes = plt.subplots(len(stations), len(quantities), figsize=page, squeeze=False,
                             sharex=True)
    flagged = {(f["channel"], f["quantity"], f["day"]) for f in flags}
    for row, sta in zip(axes, stations):
        for ax, quantity in zip(row, quantities):
            for (s, cid), series in sorted(_series(rows, quantity).items()):
                if s != sta:
                    continue
                days = [_date(d[0]) for d in series]
                dev, lo, hi = (np.array([d[k] for d in series]) for k in (1, 2, 3))
                line, = ax.plot(days, dev, "o-", ms=4, label=cid.split(".")[-1])
                ax.fill_between(days, lo, hi, color=line.get_color(), alpha=0.25, lw=0)
                ax.errorbar(days, dev, yerr=[dev - lo, hi - dev], fmt="none",
                            ecolor=line.get_color(), capsize=3)
                bad = [(d, v) for d, v, s_ in zip(days, dev, series)
                       if (cid, quantity, s_[0]) in flagged]
                if bad:
                    ax.plot(*zip(*bad), "x", color="red", ms=11, mew=2.5)
            for f in flags:
                if f["station"] == sta and f["quantity"] == quantity and f["flag"] == "changed":
                    ax.axvline(_date(f["day"]), color="red", ls="--", lw=1)
            thr, unit = (gain_threshold_pct, "%") if quantity == "gain" else (threshold_deg, "deg")
            for y in (-thr, thr):
                ax.axhline(y, color="grey", ls=":", lw=1)
            ax.axhline(0, color="k", lw=0.6)
            ax.set_ylabel(f"{quantity} - nominal ({unit})")
            ax.set_title(f"{sta}: {quantity}", fontsize=10, loc="left")
            if ax.get_legend_handles_labels()[0]:
                ax.legend(fontsize=7, loc="best")
    import matplotlib.dates as mdates
    for ax in axes[-1]:
        ax.xaxis.set_major_locator(mdates.AutoDateLocator(minticks=2, maxticks=10))
        ax.xaxis.set_major_formatter(mdates.DateFormatter("%Y-%m-%d"))
    fig.autofmt_xdate()
    fig.suptitle("Orientation (and gain) against time (median, 95 % credible band;\nred x: "
                 "flagged, red dashed: changed from the day before; "
                 f"dotted: thresholds +-{threshold_deg:g} deg, +-{gain_threshold_pct:g} %)",
                 fontsize=9)
    fig.tight_layout()
    return fig


def _text_page(rows, flags, threshold_deg, gain_threshold_pct, page):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    labels = sorted({r["label"] for r in rows})
    errors = sorted({(r["label"], r["error"]) for r in rows if r.get("error")})
    ok = [r for r in rows if not r.get("error")]
    chains = [r for r in ok if r["ess_min"] is not None]      # a Laplace approximation has none
    lines = [f"bayescal batch: {len(labels)} items, {len(labels) - len(errors)} calibrated, "
             f"{len(errors)} failed",
             (f"convergence: min ESS {min(r['ess_min'] for r in chains):.0f}, max R-hat "
              f"{max(r['rhat_max'] for r in chains):.4f}, max tau "
              f"{max(r['tau_max'] for r in chains):.0f};"
              f" not converged: {sorted({r['label'] for r in ok if r['converged'] != 'True'})}"
              if chains else "convergence: no chain"),
             f"thresholds: {threshold_deg:g} deg (angles), {gain_threshold_pct:g} % (gain); "
             "flag = beyond threshold AND beyond the 95 % uncertainty", "",
             f"Flagged stations ({len({f['station'] for f in flags})}):"]
    for f in flags[:40]:
        when = f"{f['previous_day']} -> {f['day']}" if f["flag"] == "changed" else f["day"]
        lines.append(f"  {f['channel']:<18} {f['quantity']:<7} {f['flag']:<11} {when:<24} "
                     f"{f['value']:+8.2f} {f['unit']} [{f['lo95']:+.2f}, {f['hi95']:+.2f}]")
    if not flags:
        lines.append("  none")
    lines += ["", "Failed items:"] + [f"  {lb}: {err}"[:110] for lb, err in errors[:30]]
    if not errors:
        lines.append("  none")
    fig = plt.figure(figsize=page)
    fig.text(0.04, 0.96, "\n".join(lines), va="top", family="monospace", fontsize=7)
    return fig


def write_report(results_csv, out, threshold_deg=2.0, gain_threshold_pct=2.0, per_page=6,
                 paper="a4"):
    """``flags.csv``, ``report.pdf`` (summary page + orientation pages, every
    page of ``paper``, "a4" or "letter") and ``report.png`` (first
    orientation page) in ``out``; returns their paths and the flags."""
    import matplotlib
    matplotlib.use("Agg")

    rows = read_results(results_csv)
    flags = find_flags(rows, threshold_deg, gain_threshold_pct)
    paths = {"flags": os.path.join(out, "flags.csv"), "pdf": os.path.join(out, "report.pdf"),
             "png": os.path.join(out, "report.png")}
    _write_csv(paths["flags"], FLAG_COLUMNS, flags)
    stations = sorted({r["station"] for r in rows if r.get("station") and not r.get("error")})
    groups = [stations[k:k + per_page] for k in range(0, len(stations), per_page)]
    page = page_size(paper)

    def pages():
        yield None, _text_page(rows, flags, threshold_deg, gain_threshold_pct, page)
        for k, stas in enumerate(groups):
            yield (paths["png"] if k == 0 else None), _figure(rows, flags, stas, threshold_deg,
                                                              gain_threshold_pct, page)
    write_pages(pages(), paths["pdf"], page=page, dpi=90, grey=False)
    return {**paths, "flag_list": flags}
