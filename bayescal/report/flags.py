"""The flag rule the fit report and the batch report share.

A quantity is flagged off nominal when its estimate differs from the
StationXML value by more than the threshold AND its 95 % credible interval
excludes the nominal value (:func:`off_nominal`): a deviation the data
cannot tell from nominal is not flagged, however large its median.

* ``bayescal report`` (:func:`bayescal.report.tables.angle_rows`) applies it
  to each channel's azimuth and dip, and to a near-vertical channel's tilt
  from the vertical, with the tolerance in degrees (default
  :data:`FLAG_THRESHOLD_DEG`).
* ``bayescal batch`` (:func:`find_flags`) applies it to azimuth, dip and
  gain (threshold in percent, default :data:`FLAG_THRESHOLD_PCT`), per pair
  and day, and adds the ``changed`` flag between consecutive results of one
  pair (rule in :mod:`bayescal.report.batch`).
"""
from __future__ import annotations

import numpy as np

#: Default flag thresholds: angles (degrees) and gains (percent).
FLAG_THRESHOLD_DEG = 2.0
FLAG_THRESHOLD_PCT = 2.0

FLAG_COLUMNS = ("station", "channel", "reference_channels", "quantity", "flag", "day",
                "previous_day", "label", "previous_label", "value", "lo95", "hi95", "reference",
                "threshold", "unit")


def off_nominal(deviation, lo95, hi95, threshold):
    """True when a quantity is off nominal: ``|deviation| > threshold`` and
    its 95 % interval ``[lo95, hi95]`` (of the deviation, estimate minus
    nominal) excludes 0, i.e. the interval of the estimate excludes the
    nominal value.

    Parameters
    ----------
    deviation : float, estimate (median) minus nominal.
    lo95, hi95 : float, bounds of the deviation's 95 % interval.
    threshold : float, in the deviation's unit.
    """
    return bool(abs(deviation) > threshold and not lo95 <= 0.0 <= hi95)


def deviation_interval(entry, deviation):
    """``(lo95, hi95)`` of ``deviation``, the deviation from nominal of a
    result.json entry (``median``, ``ci95``): the entry's 95 % interval
    moved with its median (an azimuth's wrapped deviation keeps its interval)."""
    lo, hi = entry["ci95"]
    return deviation - (entry["median"] - lo), deviation + (hi - entry["median"])


def entry_off_nominal(entry, deviation, threshold):
    """:func:`off_nominal` of a result.json entry (``median``, ``ci95``)
    whose deviation from nominal is ``deviation``."""
    return off_nominal(deviation, *deviation_interval(entry, deviation), threshold)


def wrap_deg(d):
    """Angle difference ``d`` (degrees) wrapped into [-180, 180)."""
    return (d + 180.0) % 360.0 - 180.0


def deviation_series(rows, quantity):
    """Per pair (station, SUT channel, reference channels): the list of
    (day, label, dev, lo, hi, nominal) of the deviation from nominal
    (degrees, or percent for the gain), in order of day and label."""
    out = {}
    for r in rows:
        val, nom = r.get(quantity), r.get(f"nominal_{quantity}")
        if r.get("error") or val is None or nom is None or r.get(f"{quantity}_lo95") is None:
            continue
        lo, hi = r[f"{quantity}_lo95"], r[f"{quantity}_hi95"]
        if quantity == "gain":
            dev, dlo, dhi = (100.0 * (x / nom - 1.0) for x in (val, lo, hi))
        else:
            dev = wrap_deg(val - nom) if quantity == "azimuth" else val - nom
            dlo, dhi = deviation_interval({"median": val, "ci95": (lo, hi)}, dev)
        key = (r["station"], r["channel"], r.get("reference_channels") or "")
        out.setdefault(key, []).append((r["day"], r["label"], dev, dlo, dhi, nom))
    return {k: sorted(v) for k, v in out.items()}


def find_flags(rows, threshold_deg=FLAG_THRESHOLD_DEG, gain_threshold_pct=FLAG_THRESHOLD_PCT):
    """Flags (list of dicts, columns :data:`FLAG_COLUMNS`) from results rows
    (:func:`bayescal.report.batch.read_results`), by the rule of
    :mod:`bayescal.report.batch`; each pair's results form one series."""
    flags = []
    for quantity, thr, unit in (("azimuth", threshold_deg, "deg"), ("dip", threshold_deg, "deg"),
                                ("gain", gain_threshold_pct, "%")):
        for (sta, cid, refs), series in sorted(deviation_series(rows, quantity).items()):
            base = {"station": sta, "channel": cid, "reference_channels": refs,
                    "quantity": quantity, "threshold": thr, "unit": unit}
            for day, label, dev, lo, hi, nom in series:
                if off_nominal(dev, lo, hi, thr):
                    flags.append({**base, "flag": "off_nominal", "day": day, "previous_day": "",
                                  "label": label, "previous_label": "", "value": dev,
                                  "lo95": lo, "hi95": hi, "reference": nom})
            for before, after in zip(series, series[1:]):
                flag = _change(before, after, quantity, thr)
                if flag:
                    flags.append({**base, **flag})
    return flags


def _change(before, after, quantity, thr):
    """The ``changed`` flag's entries between two results of one pair, or None."""
    (d0, lb0, v0, lo0, hi0, _), (d1, lb1, v1, lo1, hi1, _) = before, after
    delta = wrap_deg(v1 - v0) if quantity == "azimuth" else v1 - v0
    combined = np.hypot((hi0 - lo0) / 2, (hi1 - lo1) / 2)
    if not (abs(delta) > thr and abs(delta) > combined):
        return None
    return {"flag": "changed", "day": d1, "previous_day": d0, "label": lb1,
            "previous_label": lb0, "value": delta, "lo95": delta - combined,
            "hi95": delta + combined, "reference": v0}
