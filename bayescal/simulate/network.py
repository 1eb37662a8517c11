"""A simulated network for batch calibration: an SDS archive of several
stations and days with known truth.

Every station has a reference (location ``00``) and a sensor under test
(location ``10``) beside it. Each station-day is one call to
:func:`bayescal.simulate.simulate_pair` (its own seed), written in the SDS
layout ObsPy reads (``YEAR/NET/STA/CHAN.D/NET.STA.LOC.CHAN.D.YEAR.DOY``). The
StationXML holds the *nominal* metadata and never changes; the truth does:
each SUT sits a small, fixed angle off its nominal azimuth, and one station's
SUT is turned by ``rotation_deg`` from day ``rotate_from_day`` on (a sensor
re-installed rotated, metadata not updated).

    >>> from bayescal.simulate.network import write_network
    >>> net = write_network("/tmp/net")          # 3 stations x 3 days
    >>> net["archive"], net["inventory"], net["truth"]
"""
from __future__ import annotations

import json
import os
import zlib

import numpy as np
from obspy import Inventory, UTCDateTime

from .pair import simulate_pair


def sds_path(root, network, station, location, channel, day, sds_type="D"):
    """Path of one channel-day file in an SDS archive (ObsPy's layout)."""
    t = UTCDateTime(day)
    return os.path.join(root, f"{t.year}", network, station, f"{channel}.{sds_type}",
                        f"{network}.{station}.{location}.{channel}.{sds_type}."
                        f"{t.year}.{t.julday:03d}")


def station_codes(n):
    """Station codes ``ST01``, ``ST02``, ... for ``n`` stations."""
    return [f"ST{k + 1:02d}" for k in range(n)]


def _seed_for(seed, *parts):
    """A stable 31-bit seed from a global seed and labels (not Python's
    salted ``hash``)."""
    return zlib.crc32(":".join(str(p) for p in (seed, *parts)).encode()) & 0x7FFFFFFF


def write_network(folder, *, n_stations=3, n_days=3, start="2026-01-01", duration=3600.0, fs=10.0,
                  seed=0, coherence=0.99, network="XX", rotated_station="ST02", rotation_deg=5.0,
                  rotate_from_day=None, max_offset_deg=0.5):
    """Write the archive, the StationXML and the truth under ``folder``.

    Parameters
    ----------
    n_stations, n_days : network size; one recording of ``duration`` seconds
        at ``fs`` Hz per station and day, starting at 00:00 UTC.
    rotated_station : station whose SUT turns (None for none).
    rotation_deg : how far it turns (clockwise seen from above).
    rotate_from_day : index of the first turned day (default: halfway,
        ``n_days // 2``).
    max_offset_deg : every SUT's fixed azimuth offset from nominal is drawn
        uniformly in +- this value.

    Returns a dict with ``archive`` (SDS root), ``inventory`` (StationXML
    folder, one file per station), ``truth`` (JSON path), ``stations``,
    ``days`` (ISO dates) and ``rotation`` (station, first day, degrees).
    """
    rotate_from_day = n_days // 2 if rotate_from_day is None else rotate_from_day
    archive = os.path.join(folder, "sds")
    xml_dir = os.path.join(folder, "stationxml")
    os.makedirs(xml_dir, exist_ok=True)
    t_start = UTCDateTime(start)
    days = [(t_start + 86400 * d) for d in range(n_days)]
    rng = np.random.default_rng(seed)
    truth = {"network": network, "days": [d.date.isoformat() for d in days], "stations": {},
             "rotation": None}
    if rotated_station:
        truth["rotation"] = {"station": rotated_station, "degrees": rotation_deg,
                             "from_day": days[rotate_from_day].date.isoformat()}
    for sta in station_codes(n_stations):
        offset = float(rng.uniform(-max_offset_deg, max_offset_deg))
        truth["stations"][sta] = {"azimuth_offset_deg": offset, "days": {}}
        inventory = None
        for d, day in enumerate(days):
            turn = rotation_deg if (sta == rotated_station and d >= rotate_from_day) else 0.0
            az = offset + turn
            sim = simulate_pair(duration=duration, fs=fs, seed=_seed_for(seed, sta, d),
                                coherence=coherence, sut_azimuth=(az, 90.0 + az, 0.0),
                                network=network, station=sta, start=day)
            for tr in list(sim.sut) + list(sim.ref):
                s = tr.stats
                path = sds_path(archive, s.network, s.station, s.location, s.channel, day)
                os.makedirs(os.path.dirname(path), exist_ok=True)
                tr.write(path, format="MSEED", encoding="FLOAT64")
            truth["stations"][sta]["days"][day.date.isoformat()] = sim.truth["channels"]
            if inventory is None:   # nominal metadata: the same for every day
                inventory = _merge(sim.sut_inventory, sim.ref_inventory)
        inventory.write(os.path.join(xml_dir, f"{network}.{sta}.xml"), format="STATIONXML")
    truth_path = os.path.join(folder, "truth.json")
    with open(truth_path, "w") as fh:
        json.dump(truth, fh, indent=2)
    return {"archive": archive, "inventory": xml_dir, "truth": truth_path,
            "stations": station_codes(n_stations), "days": truth["days"],
            "rotation": truth["rotation"]}


def _merge(sut_inv, ref_inv):
    """One inventory holding both sensors of a station."""
    inv = Inventory(networks=[sut_inv[0].copy()], source=sut_inv.source)
    inv[0][0].channels = list(ref_inv[0][0].channels) + list(inv[0][0].channels)
    return inv
