"""Recordings in: ObsPy Streams and Inventories to aligned sample arrays,
channel axes and responses.

Errors are raised as :class:`InputError` with one clear sentence naming the
file (or stream) and the problem; the command line turns them into a message
and exit code 2.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .geometry import unit_vector
from .response import ResponseError, TwoPoleFamily, evaluate_velocity_response


class InputError(ValueError):
    """Bad input data or metadata; the message names the source and problem."""


@dataclass
class Side:
    """One sensor's channels, aligned on the common grid."""

    ids: list             # SEED ids
    data: np.ndarray      # (n, N) counts, NaN in gaps
    vectors: np.ndarray   # (n, 3) axes from StationXML
    responses: list       # ObsPy Response per channel
    azimuths: list
    dips: list
    source: str = "stream"

    def response_fn(self):
        """Callable freqs -> (n, F) complex velocity responses."""
        return lambda f: np.array([evaluate_velocity_response(r, f) for r in self.responses])

    def families(self):
        out = []
        for r in self.responses:
            try:
                out.append(TwoPoleFamily.from_response(r))
            except ResponseError:
                out.append(None)
        return out


def _channel_meta(inventory, tr, source):
    try:
        ch = inventory.select(network=tr.stats.network, station=tr.stats.station,
                              location=tr.stats.location, channel=tr.stats.channel,
                              time=tr.stats.starttime)[0][0][0]
    except IndexError:
        raise InputError(f"{source}: channel {tr.id} is not in the StationXML") from None
    if ch.azimuth is None or ch.dip is None:
        raise InputError(f"{source}: channel {tr.id} has no azimuth/dip in the StationXML")
    if ch.response is None or not ch.response.response_stages:
        raise InputError(f"{source}: channel {tr.id} has no response in the StationXML")
    return ch


def align(sut, sut_inventory, ref, ref_inventory, sut_source="SUT", ref_source="reference",
          start=None, end=None):
    """Bring both streams onto one time grid and read their metadata.

    Returns ``(sut_side, ref_side, fs, starttime)``. Gaps become NaN.
    """
    sides = []
    fs_all = {tr.stats.sampling_rate for st in (sut, ref) for tr in st}
    if len(fs_all) != 1:
        raise InputError(f"sampling rates differ between channels: {sorted(fs_all)} Hz")
    fs = fs_all.pop()
    t0 = max(tr.stats.starttime for st in (sut, ref) for tr in st)
    t1 = min(tr.stats.endtime for st in (sut, ref) for tr in st)
    if start is not None:
        t0 = max(t0, start)
    if end is not None:
        t1 = min(t1, end)
    if t1 <= t0:
        raise InputError(f"{sut_source} and {ref_source} do not overlap in time")
    n = int(np.floor((t1 - t0) * fs)) + 1
    for st, inv, source in ((sut, sut_inventory, sut_source), (ref, ref_inventory, ref_source)):
        st = st.copy()
        st.merge(method=0, fill_value=None)
        ids, data, vecs, resps, azs, dips = [], [], [], [], [], []
        for tr in st:
            ch = _channel_meta(inv, tr, source)
            off = int(round((tr.stats.starttime - t0) * fs))
            x = np.full(n, np.nan)
            src = np.ma.filled(np.ma.masked_invalid(tr.data.astype(float)), np.nan) \
                if np.ma.isMaskedArray(tr.data) else tr.data.astype(float)
            lo, hi = max(off, 0), min(off + src.size, n)
            if hi > lo:
                x[lo:hi] = src[lo - off:hi - off]
            ids.append(tr.id)
            data.append(x)
            vecs.append(unit_vector(ch.azimuth, ch.dip))
            resps.append(ch.response)
            azs.append(float(ch.azimuth))
            dips.append(float(ch.dip))
        sides.append(Side(ids=ids, data=np.array(data), vectors=np.array(vecs), responses=resps,
                          azimuths=azs, dips=dips, source=source))
    return sides[0], sides[1], fs, t0
