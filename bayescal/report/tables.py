"""The numbers of the fit report: table rows with medians, intervals, nominal
values, deviations and flags, and the simulation truth when there is one.
"""
from __future__ import annotations

import json
import os
from dataclasses import dataclass

import numpy as np

from ..core.orientation import NEAR_VERTICAL_DIP_DEG, unit_vector
from ..errors import InputError
from .flags import entry_off_nominal


#: A channel whose axis lies within this angle (degrees) of the opposite of
#: its nominal axis is flagged as reversed (polarity or a 180 degree turn).
REVERSED_WITHIN_DEG = 20.0


@dataclass
class Row:
    """One line of the summary table (angles in degrees)."""

    channel: str
    quantity: str          # "azimuth", "dip", "tilt", "period_s", "damping", "gain",
    #                        "relative_gain" (fitted / metadata gain)
    median: float | None
    ci68: list | None
    ci95: list | None
    nominal: float | None
    deviation: float | None
    note: str = ""
    truth: float | None = None
    unit: str | None = None    # the metadata's (a gain's, e.g. "V/(m/s)"); None: the quantity's


def wrap180(x):
    """Angle difference wrapped into (-180, 180] degrees."""
    return 180.0 - (180.0 - np.asarray(x, float)) % 360.0


def load_truth(folder, meta, truth=None):
    """Simulation truth for truth markers, or None.

    ``truth`` may be a dict (simulate's format ``{"channels": {id: {...}}}``)
    or a path to a JSON file; otherwise the meta's ``truth`` entry, otherwise
    ``folder/truth.json`` when present.
    """
    if truth is None and meta.extra.get("truth"):
        truth = meta.extra["truth"]
    if truth is None:
        path = os.path.join(folder, "truth.json")
        truth = path if os.path.exists(path) else None
    if isinstance(truth, (str, os.PathLike)):
        try:
            with open(truth) as fh:
                truth = json.load(fh)
        except (OSError, ValueError) as exc:
            raise InputError(f"{truth}: cannot read the truth file ({exc})") from None
    if truth is not None and not isinstance(truth.get("channels"), dict):
        raise InputError(f"{folder}: truth has no 'channels' mapping")
    return truth


def _axis_angle(vectors, nominal):
    """Angle (degrees) between the mean sampled axis and the nominal axis."""
    v = np.mean(vectors, axis=0)
    v /= np.linalg.norm(v)
    n = unit_vector(nominal["azimuth_deg"], nominal["dip_deg"])
    return float(np.degrees(np.arccos(np.clip(v @ n, -1.0, 1.0))))


def interval_row(cid, quantity, entry, nominal, deviation, note="", truth=None):
    if entry.get("multimodal"):       # one mode's interval: core.posterior.modes.mark
        note = "multimodal: see modes" + (f"; {note}" if note else "")
    return Row(cid, quantity, entry.get("median"), entry.get("ci68"), entry.get("ci95"),
               nominal, deviation, note, truth)


def angle_rows(post, summary, tolerance_deg, truth=None):
    """Summary-table rows for the angles and the flags raised, per channel.

    Returns ``(rows, flags)``; ``flags`` maps a channel id to a list of
    messages (azimuth, dip or tilt off nominal by more than
    ``tolerance_deg`` with its 95 % interval excluding nominal, the rule of
    ``bayescal batch``, :func:`bayescal.report.flags.off_nominal`; axis
    reversed). ``truth`` (simulate's format) fills
    :attr:`Row.truth`.
    """
    rows, flags = [], {}
    for k, cid in enumerate(post.channel_ids):
        ch = summary["channels"][cid]
        nom = ch.get("nominal") or {}
        naz, ndip = nom.get("azimuth_deg"), nom.get("dip_deg")
        az, dip = ch["azimuth_deg"], ch["dip_deg"]
        tru = truth_values(truth, cid)
        msgs = []
        if naz is not None and ndip is not None:
            angle = _axis_angle(post.vectors[:, k], nom)
            if angle > 180.0 - REVERSED_WITHIN_DEG:
                msgs.append(f"REVERSED: axis {angle:.1f} deg from nominal (polarity or 180 deg turn)")
        if post.kinds[k] == "fixed":
            rows += _fixed_rows(cid, az, dip, naz, ndip, tru)
        elif "tilt_deg" in ch:
            rows.append(Row(cid, "azimuth", None, None, None, naz, None,
                            "undefined (near-vertical): see tilt", tru.get("azimuth_deg")))
            ntilt = None if ndip is None else 90.0 - abs(ndip)
            tilt = ch["tilt_deg"]
            dev = None if ntilt is None else tilt["median"] - ntilt
            ttilt = 90.0 - abs(tru["dip_deg"]) if "dip_deg" in tru else None
            lean = ("vertical within the 95 % region" if tilt.get("holds_zero")
                    else f"toward az {ch['tilt_toward_azimuth_deg']:.1f}")
            rows.append(interval_row(cid, "tilt", tilt, ntilt, dev, lean, ttilt))
            if dev is not None and entry_off_nominal(tilt, dev, tolerance_deg) and not msgs:
                msgs.append(f"TILT OFF: {dev:+.2f} deg from nominal (tolerance {tolerance_deg:g})")
        else:
            dev = None if naz is None else float(wrap180(az["median"] - naz))
            note = "fixed (not estimable)" if az.get("fixed") else ""
            rows.append(interval_row(cid, "azimuth", az, naz, dev, note, tru.get("azimuth_deg")))
            if (dev is not None and not az.get("fixed") and not msgs
                    and entry_off_nominal(az, dev, tolerance_deg)):
                msgs.append(f"AZIMUTH OFF: {dev:+.2f} deg from nominal (tolerance {tolerance_deg:g})")
        if post.kinds[k] != "fixed":
            ddev = None if ndip is None else dip["median"] - ndip
            note = "fixed (reference plane)" if dip.get("fixed") else ""
            rows.append(interval_row(cid, "dip", dip, ndip, ddev, note, tru.get("dip_deg")))
            if ("tilt_deg" not in ch and ddev is not None and not msgs and not dip.get("fixed")
                    and entry_off_nominal(dip, ddev, tolerance_deg)):
                msgs.append(f"DIP OFF: {ddev:+.2f} deg from nominal (tolerance {tolerance_deg:g})")
        if msgs:
            flags[cid] = msgs
    for pair, e in summary.get("orthogonality_deg", {}).items():   # ASL's orthogonality
        note = "assumed (one reference channel)" if e.get("assumed") else "angle between axes"
        rows.append(interval_row(pair, "orthogonality", e, 90.0, e["median"] - 90.0, note))
    return rows, flags


def _fixed_rows(cid, az, dip, naz, ndip, tru):
    """Rows of a channel held along the reference axis (direction not
    estimated; only its response may be fitted)."""
    note = "held along the reference axis: not estimated"
    rows = []
    if abs(dip["median"]) <= NEAR_VERTICAL_DIP_DEG:
        dev = None if naz is None else float(wrap180(az["median"] - naz))
        rows.append(Row(cid, "azimuth", az["median"], None, None, naz, dev, note,
                        tru.get("azimuth_deg")))
    ddev = None if ndip is None else dip["median"] - ndip
    rows.append(Row(cid, "dip", dip["median"], None, None, ndip, ddev, note, tru.get("dip_deg")))
    return rows


def response_rows(summary, truth=None):
    """Summary-table rows for fitted response parameters; deviation in % of
    the nominal value."""
    rows = []
    for cid, ch in summary["channels"].items():
        nom = ch.get("nominal") or {}
        tru = truth_values(truth, cid)
        for name, entry in (ch.get("response") or {}).items():
            n = nom.get(name)
            true = tru.get(name)
            if name == "relative_gain":        # fitted / metadata gain: nominal 1
                n = 1.0
                true = tru["gain"] / nom["gain"] if "gain" in tru and nom.get("gain") else None
            elif name == "damping_over_period" and nom.get("period_s"):
                n = nom["damping"] / nom["period_s"]
                true = tru["damping"] / tru["period_s"] if "period_s" in tru else None
            dev = None if not n else 100.0 * (entry["median"] / n - 1.0)
            note = ("SET BY THE PRIOR: held at nominal" if entry.get("action") == "held at nominal"
                    else "SET BY THE PRIOR: not measured"
                    if entry.get("set_by_prior") else "")
            if not two_pole_nominal(nom):      # gain-only ('flat') metadata: no nominal response
                dev, note = None, note or "gain-only metadata: no nominal to deviate from"
            if entry.get("set_by_prior") and entry.get("action", "").startswith("not measured"):
                # the prior's value is not a measurement: no number is shown
                rows.append(Row(cid, name, None, None, None, n, None, note, true,
                                nom.get("gain_units") if name == "gain" else None))
                continue
            row = interval_row(cid, name, entry, n, dev, note, truth=true)
            row.unit = nom.get("gain_units") if name == "gain" else None
            rows.append(row)
    return rows


def two_pole_nominal(nominal):
    """Whether a channel's metadata give a two-pole velocity response (a
    natural period), rather than a gain alone ('flat' or one gain stage)."""
    return nominal.get("period_s") is not None


def truth_values(truth, cid):
    """Truth entry of one channel, or an empty dict."""
    if not truth:
        return {}
    return truth["channels"].get(cid, {})
