"""What a batch run has to do: a plan of items, each one SUT/reference pair.

An item is a small JSON-able dict (file paths and fit options, never data),
so it can be shipped to any Dask worker that sees the same file system.
Two ways to make a plan:

* :func:`read_csv_plan` -- a CSV table with at least the columns
  ``label,ref,ref_xml,sut,sut_xml`` (several waveform files separated by
  ``;``), optional ``band_min,band_max,fit_response,seed,start,end,sut_id,ref_id``
  (the last two SEED-id patterns such as ``XX.SIM.10.BH?``, several separated
  by ``;``, choosing each sensor's channels in files holding both);
* :func:`sds_plan` -- an SDS archive and its StationXML with the rule "at
  every station, location ``sut_location`` against ``ref_location``, one item
  per day".

:func:`read_sds_item` reads an SDS item's recordings (ObsPy) on the worker;
file items go to :func:`bayescal.pair.workflow.calibrate_files`.
"""
from __future__ import annotations

import csv
import functools
import glob
import os
import re

from obspy import Inventory, UTCDateTime

from ..errors import InputError
from ..io.read import read_metadata

REQUIRED = ("label", "ref", "ref_xml", "sut", "sut_xml")
OPTIONAL = ("band_min", "band_max", "fit_response", "seed", "start", "end", "sut_id", "ref_id")
FIT_RESPONSE = ("none", "gain", "all")
#: SEED band codes from the highest sampling rate to the lowest.
BAND_ORDER = "FGDCESHBMLVUWRPTQ"
_SDS_NAME = re.compile(r"^([^.]+)\.([^.]+)\.([^.]*)\.([^.]+)\.(\w)\.(\d{4})\.(\d{3})$")
_LABEL = re.compile(r"^[A-Za-z0-9][A-Za-z0-9_.\-]*$")


def check_label(label, source):
    """A label becomes a folder name: letters, digits, ``_ . -`` only."""
    if not _LABEL.match(label or ""):
        raise InputError(f"{source}: label {label!r} is not usable as a folder name "
                         "(letters, digits, '_', '.', '-'; not starting with '.')")
    return label


def _options(row, source, defaults):
    opts = dict(defaults)
    band = [(row.get(k) or "").strip() for k in ("band_min", "band_max")]
    if any(band):
        try:
            opts["band"] = [float(b) for b in band]
        except ValueError:
            raise InputError(f"{source}: band_min/band_max {band} need two numbers") from None
    if opts["band"] is not None and not 0 < opts["band"][0] < opts["band"][1]:
        raise InputError(f"{source}: band {opts['band']} Hz is not 0 < min < max")
    fr = (row.get("fit_response") or "").strip() or opts["fit_response"]
    if fr not in FIT_RESPONSE:
        raise InputError(f"{source}: fit_response {fr!r} is not one of {', '.join(FIT_RESPONSE)}")
    opts["fit_response"] = fr
    if (row.get("seed") or "").strip():
        try:
            opts["seed"] = int(row["seed"])
        except ValueError:
            raise InputError(f"{source}: seed {row['seed']!r} is not an integer") from None
    for key in ("start", "end"):
        if (row.get(key) or "").strip():
            try:
                opts[key] = str(UTCDateTime(row[key].strip()))
            except Exception:
                raise InputError(f"{source}: {key} {row[key]!r} is not a time") from None
    for key in ("sut_id", "ref_id"):   # SEED-id patterns, several separated by ';'
        pats = [p.strip() for p in (row.get(key) or "").split(";") if p.strip()]
        if pats:
            opts[key] = pats
    return opts


def default_options(band=None, fit_response="gain"):
    """Fit options an item takes when its plan does not say (``band`` None:
    chosen from each pair's coherence, as ``bayescal fit`` does)."""
    return {"band": None if band is None else [float(b) for b in band],
            "fit_response": fit_response, "seed": None, "start": None, "end": None}


def read_csv_plan(path, defaults=None):
    """Items from a CSV plan; relative paths are taken from the CSV's folder."""
    defaults = defaults or default_options()
    if not os.path.isfile(path):
        raise InputError(f"{path}: plan file not found")
    base = os.path.dirname(os.path.abspath(path))
    with open(path, newline="") as fh:
        rows = list(csv.DictReader(fh))
        columns = rows[0].keys() if rows else []
    missing = [c for c in REQUIRED if c not in columns]
    if not rows or missing:
        raise InputError(f"{path}: plan needs the columns {','.join(REQUIRED)}"
                         + (f" (missing: {', '.join(missing)})" if rows else " and one row"))
    items, seen = [], set()
    for n, row in enumerate(rows, start=2):
        where = f"{path} line {n}"
        label = check_label((row["label"] or "").strip(), where)
        if label in seen:
            raise InputError(f"{where}: label {label!r} appears twice")
        seen.add(label)

        def paths(key):
            return [p.strip() if p.strip().lower() == "flat" else os.path.join(base, p.strip())
                    for p in (row[key] or "").split(";") if p.strip()]

        item = {"label": label, "kind": "files", "sut": paths("sut"), "ref": paths("ref"),
                "sut_xml": paths("sut_xml"), "ref_xml": paths("ref_xml"),
                **_options(row, where, defaults)}
        for key in ("sut_xml", "ref_xml"):
            if len(item[key]) > 1:
                raise InputError(f"{where}: column {key} takes one StationXML file (or 'flat')")
            item[key] = (item[key] or [""])[0]
        for key in ("sut", "ref", "sut_xml", "ref_xml"):
            if not item[key]:
                raise InputError(f"{where}: column {key} is empty")
        items.append(item)
    return items


def scan_sds(archive, sds_type="D"):
    """``{(net, sta): {loc: {chan: set of ISO days}}}`` from the file names
    of an SDS archive."""
    if not os.path.isdir(archive):
        raise InputError(f"{archive}: SDS archive folder not found")
    found = {}
    for path in glob.iglob(os.path.join(archive, "*", "*", "*", f"*.{sds_type}", "*")):
        m = _SDS_NAME.match(os.path.basename(path))
        if not m:
            continue
        net, sta, loc, cha, _, year, doy = m.groups()
        day = UTCDateTime(year=int(year), julday=int(doy)).date.isoformat()
        found.setdefault((net, sta), {}).setdefault(loc, {}).setdefault(cha, set()).add(day)
    if not found:
        raise InputError(f"{archive}: no SDS files (YEAR/NET/STA/CHAN.{sds_type}/"
                         f"NET.STA.LOC.CHAN.{sds_type}.YEAR.DOY) found")
    return found


def _pick_band(sut_chans, ref_chans):
    """The highest-rate band code with a 3-component set at both locations."""
    for b in BAND_ORDER:
        if len([c for c in sut_chans if c[0] == b]) >= 3 and \
                len([c for c in ref_chans if c[0] == b]) >= 3:
            return b
    return None


def sds_plan(archive, inventory, sut_location="10", ref_location="00", days=None,
             defaults=None, sds_type="D"):
    """One item per station and day where both locations have data.

    ``days`` is an optional ``(first, last)`` pair of dates (inclusive).
    ``inventory`` is a StationXML file or a folder of them. Labels are
    ``NET.STA.YYYY-MM-DD``.
    """
    defaults = defaults or default_options()
    read_inventories(inventory)   # fail early, naming the file, if unreadable
    lo = hi = None
    if days is not None:
        try:
            lo, hi = (UTCDateTime(str(d)).date.isoformat() for d in days)
        except Exception:
            raise InputError(f"{archive}: --days {' '.join(map(str, days))}: need two dates "
                             "YYYY-MM-DD") from None
    items = []
    for (net, sta), locs in sorted(scan_sds(archive, sds_type).items()):
        if sut_location not in locs or ref_location not in locs:
            continue
        band = _pick_band(locs[sut_location], locs[ref_location])
        if band is None:
            continue
        common = set.intersection(*[d for loc in (sut_location, ref_location)
                                    for c, d in locs[loc].items() if c[0] == band])
        for day in sorted(common):
            if (lo and day < lo) or (hi and day > hi):
                continue
            t0 = UTCDateTime(day)
            opts = dict(defaults)
            opts["start"] = opts["start"] or str(t0)
            opts["end"] = opts["end"] or str(t0 + 86400)
            items.append({"label": f"{net}.{sta}.{day}", "kind": "sds", "archive": archive,
                          "sds_type": sds_type, "inventory": inventory, "network": net,
                          "station": sta, "day": day, "sut_location": sut_location,
                          "ref_location": ref_location, "channels": f"{band}??", **opts})
    if not items:
        raise InputError(f"{archive}: no station has both location {sut_location!r} and "
                         f"{ref_location!r} on the same day" + (f" in {days}" if days else ""))
    return items


@functools.lru_cache(maxsize=16)
def read_inventories(path):
    """An Inventory from a StationXML file or from every file of a folder
    (cached per process: a worker reads a network's metadata once)."""
    if not os.path.isdir(path):
        return read_metadata(path)
    files = [f for f in sorted(glob.glob(os.path.join(path, "*"))) if os.path.isfile(f)]
    if not files:
        raise InputError(f"{path}: no StationXML files in this folder")
    inv = Inventory(networks=[], source="bayescal")
    for f in files:
        inv += read_metadata(f)
    return inv


def read_sds_item(item):
    """``(sut, ref, inventory, sut_source, ref_source)`` of an SDS item, read
    with ObsPy's SDS client (on the worker)."""
    from obspy.clients.filesystem.sds import Client
    client = Client(item["archive"], sds_type=item.get("sds_type", "D"))
    inv = read_inventories(item["inventory"])
    t0, t1 = UTCDateTime(item["start"]), UTCDateTime(item["end"])
    out = []
    for loc in (item["sut_location"], item["ref_location"]):
        st = client.get_waveforms(item["network"], item["station"], loc, item["channels"], t0, t1)
        for tr in st:   # the day is [t0, t1): not the next day's first sample
            tr.trim(t0, t1 - tr.stats.delta / 2, nearest_sample=False)
        st.traces = [tr for tr in st if tr.stats.npts]
        where = f"{item['archive']} {item['network']}.{item['station']}.{loc}.{item['channels']}"
        if not st:
            raise InputError(f"{where}: no data between {t0} and {t1}")
        out.append((st, where))
    (sut, sut_src), (ref, ref_src) = out
    return sut, ref, inv, sut_src, ref_src
