"""The reference's self-noise given by the user (``bayescal fit --ref-noise-psd FILE``).

Where a pair cannot separate the reference's noise from the ground motion
(a vertical huddle: one channel per sensor), the classic remedy is a third
co-located sensor: ``bayescal noise`` estimates every sensor's self-noise
from three, and its ``noise.json`` is read here. A self-noise model of the
reference (a manufacturer's curve, an earlier estimate) can be given the
same way as a two-column text file. Accepted files:

* ``noise.json`` of ``bayescal noise`` (schema ``bayescal.noise/1``):
  ``{"sensors": {"NET.STA.LOC.CHA": {"period_s": [...], "psd_db": [...]}}}``;
  a reference channel takes the entry of its own SEED id, else the one of
  its station, location and component (last letter of the channel code);
* a text file of two columns, period in seconds and PSD in dB re 1
  (m/s^2)^2/Hz (comma or blank separated, ``#`` comments, an optional
  header line), used for every reference channel.

:func:`read_reference_noise` returns ``{id or "*": (period_s, psd_db)}``;
:func:`for_channels` picks one curve per reference channel.
"""
from __future__ import annotations

import json
import os

import numpy as np

from ..errors import InputError


def read_reference_noise(path):
    """``{channel id or "*": (period_s, psd_db)}`` from ``path`` (see module)."""
    if not os.path.isfile(path):
        raise InputError(f"{path}: no such file (--ref-noise-psd)")
    with open(path, encoding="utf-8", errors="replace") as fh:
        text = fh.read()
    if text.lstrip().startswith("{"):
        return _from_json(path, text)
    return {"*": _from_columns(path, text)}


def _from_json(path, text):
    try:
        doc = json.loads(text)
    except json.JSONDecodeError as exc:
        raise InputError(f"{path}: not valid JSON ({exc.msg}, line {exc.lineno})") from None
    sensors = doc.get("sensors") if isinstance(doc, dict) else None
    if not isinstance(sensors, dict) or not sensors:
        raise InputError(f"{path}: no \"sensors\" in it (expected bayescal noise's noise.json, "
                         "schema bayescal.noise/1)")
    out = {}
    for cid, e in sensors.items():
        try:
            out[cid] = _checked(path, e["period_s"], e["psd_db"], f" for {cid}")
        except (KeyError, TypeError):
            raise InputError(f"{path}: sensor {cid} has no period_s / psd_db lists") from None
    return out


def _from_columns(path, text):
    rows = []
    for k, line in enumerate(text.splitlines(), 1):
        line = line.split("#", 1)[0].strip()
        if not line:
            continue
        parts = line.replace(",", " ").split()
        try:
            rows.append([float(v) for v in parts[:2]])
        except ValueError:
            if rows:        # a header is allowed only before the numbers
                raise InputError(f"{path}: line {k} is not two numbers: {line!r}") from None
            continue
        if len(parts) < 2:
            raise InputError(f"{path}: line {k} has one column; expected period_s and psd_db")
    if not rows:
        raise InputError(f"{path}: no rows of period (s) and PSD (dB re 1 (m/s^2)^2/Hz)")
    arr = np.array(rows)
    return _checked(path, arr[:, 0], arr[:, 1], "")


def _checked(path, period, db, where):
    period = np.asarray(period, float)
    db = np.asarray([np.nan if v is None else v for v in db], float)
    if period.shape != db.shape:
        raise InputError(f"{path}: period_s and psd_db differ in length{where}")
    ok = np.isfinite(period) & np.isfinite(db)
    if np.any(period[ok] <= 0):
        raise InputError(f"{path}: periods must be positive{where}")
    if ok.sum() < 2:
        raise InputError(f"{path}: fewer than two finite (period, PSD) values{where}")
    if np.any((db[ok] > 0) | (db[ok] < -300)):
        raise InputError(f"{path}: PSD values outside -300..0 dB re 1 (m/s^2)^2/Hz{where}: "
                         "is the file in dB of acceleration?")
    return period[ok], db[ok]


def for_channels(table, ref_ids, source):
    """One ``(period_s, psd_db)`` per reference channel of ``ref_ids`` from
    :func:`read_reference_noise`'s ``table``; ``source`` names the file in
    the error when a channel has none."""
    out = []
    for cid in ref_ids:
        key = cid if cid in table else _same_component(table, cid)
        if key is None and "*" in table:
            key = "*"
        if key is None:
            raise InputError(f"{source}: no self-noise for reference channel {cid} (the file "
                             f"has {', '.join(sorted(table)) or 'none'})")
        out.append((key, *table[key]))
    return out


def _same_component(table, cid):
    parts = str(cid).split(".")
    if len(parts) != 4:
        return None
    net, sta, loc, cha = parts
    for key in table:
        p = key.split(".")
        if len(p) == 4 and p[:3] == [net, sta, loc] and p[3][-1:] == cha[-1:]:
            return key
    return None
