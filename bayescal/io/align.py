"""Alignment of two or more sensors' recordings on one time grid: the lowest
common sampling rate, sub-sample offsets removed by fractional delays, gaps
and clipped stretches as NaN, and each channel's metadata read (a
:class:`Side` per sensor).
"""
from __future__ import annotations

import warnings
from dataclasses import dataclass, field
from fractions import Fraction

import numpy as np

from ..core.orientation import unit_vector
from ..core.response import evaluate_velocity_response, response_family
from ..errors import InputError, InputWarning
from .read import channel_meta

#: Sub-sample offsets smaller than this fraction of a sample are rounded.
SUBSAMPLE_TOLERANCE = 0.01
#: Half-length (samples) of the fractional-delay filter.
DELAY_HALF_LENGTH = 16
#: A channel is reported as clipped when at least this many samples (and
#: this fraction of all) sit at its extreme value inside flat tops, and its
#: data hold at least CLIP_MIN_DISTINCT distinct values.
CLIP_MIN_SAMPLES = 5
CLIP_MIN_FRACTION = 1e-5
CLIP_MIN_DISTINCT = 50
#: Samples larger than this are no recording (a 32-bit digitizer gives at
#: most 2^31 counts; data in physical units are smaller still): a channel
#: holding one is refused as corrupted.
MAX_SAMPLE = 1e20


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
    sources: list = field(default_factory=list)   # file per channel

    def response_fn(self):
        """Callable freqs -> (n, F) complex velocity responses; channels
        whose responses are equal (the three components of one sensor,
        often) share one evaluation."""
        def evaluate(f):
            done = []                   # (response, its values), each distinct one once
            for r in self.responses:
                if not any(r is q or r == q for q, _ in done):
                    done.append((r, evaluate_velocity_response(r, f)))
            return np.array([next(x for q, x in done if r is q or r == q)
                             for r in self.responses])
        return evaluate

    def families(self):
        """Per channel the parametric family of its response
        (:func:`bayescal.core.response.family.response_family`: a
        :class:`TwoPoleFamily`, a gain-only :class:`ScaleFamily` when the
        first stage is not a pendulum pair, or None)."""
        return [response_family(r) for r in self.responses]

    @property
    def fraction_finite(self):
        """Fraction of grid samples present on every channel at once."""
        return float(np.mean(np.all(np.isfinite(self.data), axis=0)))


# --- reading files -----------------------------------------------------------


def _as_float(data):
    if np.ma.isMaskedArray(data):
        return np.ma.filled(data.astype(float), np.nan)
    return np.asarray(data, dtype=float)


def _resample(x, fs_in, fs_out):
    """Anti-alias filter and resample one contiguous trace; NaN edges."""
    frac = Fraction(fs_out / fs_in).limit_denominator(1000)
    if frac == 1:
        return x
    from scipy.signal import resample_poly

    up, down = frac.numerator, frac.denominator
    finite = np.isfinite(x)
    y = resample_poly(np.where(finite, x, 0.0), up, down, window=("kaiser", 8.0))
    # the FIR half-length (scipy: 10 * max(up, down) taps at the input rate)
    edge = int(np.ceil(10 * max(up, down) / down)) + 1
    mask = np.zeros(y.size, bool)
    mask[:edge] = mask[-edge:] = True
    if not finite.all():   # spread input NaNs over the filter's reach
        bad = np.zeros(y.size, bool)
        idx = np.minimum((np.flatnonzero(~finite) * up) // down, y.size - 1)
        bad[idx] = True
        mask |= np.convolve(bad, np.ones(2 * edge + 1), mode="same") > 0
    y[mask] = np.nan
    return y


def _fractional_delay(x, frac):
    """Delay ``x`` by ``frac`` of a sample (windowed sinc), NaN at the edges
    and around NaNs."""
    m = DELAY_HALF_LENGTH
    k = np.arange(-m, m + 1)
    h = np.sinc(k - frac) * np.kaiser(2 * m + 1, 8.0)
    h /= h.sum()
    finite = np.isfinite(x)
    y = np.convolve(np.where(finite, x, 0.0), h, mode="same")
    bad = np.convolve(~finite, np.ones(2 * m + 1), mode="same") > 0
    y[bad] = np.nan
    y[:m] = y[-m:] = np.nan
    return y


def _place(grid, count, tr, x, fs, t0):
    """Add samples ``x`` of trace ``tr`` onto the grid starting at ``t0``;
    overlaps whose data disagree become NaN."""
    pos = (tr.stats.starttime - t0) * fs
    off = int(np.floor(pos + SUBSAMPLE_TOLERANCE))
    frac = pos - off
    if frac > SUBSAMPLE_TOLERANCE:
        # sample j sits at grid position off + frac + j, so grid point off + j
        # holds x delayed by ``frac`` of a sample
        x = _fractional_delay(x, frac)
    n = grid.size
    lo, hi = max(off, 0), min(off + x.size, n)
    if hi <= lo:
        return
    seg = x[lo - off:hi - off]
    cur = grid[lo:hi]
    cnt = count[lo:hi]
    have = (cnt > 0) & np.isfinite(cur)
    scale = np.nanmax(np.abs(seg)) if np.isfinite(seg).any() else 0.0
    disagree = have & np.isfinite(seg) & (np.abs(cur - seg) > 1e-6 * max(scale, 1e-30))
    new = np.where(have, cur, seg)
    new[disagree] = np.nan
    grid[lo:hi] = new
    count[lo:hi] += 1


def _check_channel(x, tid, source):
    """Dead or empty channel checks on one grid channel."""
    finite = np.isfinite(x)
    if not finite.any():
        raise InputError(f"{source}: channel {tid} has no valid sample in the analysis window "
                         "(all missing or NaN)")
    vals = x[finite]
    peak = float(np.max(np.abs(vals)))
    if peak > MAX_SAMPLE:
        raise InputError(f"{source}: channel {tid} holds samples of size {peak:.3g}, far beyond "
                         "any recording's (a corrupted file?)")
    if np.all(vals == 0):
        raise InputError(f"{source}: channel {tid} is all zeros in the analysis window "
                         "(dead channel)")
    if np.ptp(vals) == 0:
        raise InputError(f"{source}: channel {tid} is constant in the analysis window "
                         "(dead channel)")


def _mask_clipped(x, tid, source):
    """Warn about, and turn into gaps, the flat tops of a clipped recording:
    runs of three or more consecutive samples sitting at the trace's extreme
    value (a natural record reaches its peak once; coarse, low-amplitude
    integer data with few distinct values are not judged)."""
    finite = np.isfinite(x)
    if not finite.any():
        return x
    vals = x[finite]
    peak = np.max(np.abs(vals))
    if peak == 0 or np.unique(vals[:100_000]).size < CLIP_MIN_DISTINCT:
        return x
    at_peak = finite & (np.abs(np.where(finite, x, 0.0)) >= peak)
    flat = at_peak & np.roll(at_peak, 1) & np.roll(at_peak, -1)
    flat[[0, -1]] = False
    n_flat = int(np.count_nonzero(flat))
    if n_flat >= max(CLIP_MIN_SAMPLES, CLIP_MIN_FRACTION * vals.size):
        warnings.warn(f"{source}: channel {tid} looks clipped ({int(at_peak.sum())} samples at "
                      f"+-{peak:g} counts, in flat tops); those samples are treated as gaps",
                      InputWarning, stacklevel=4)
        x = np.where(at_peak, np.nan, x)
    return x


def _grid_stream(stream, fs, t0, n):
    """Channels of ``stream`` on the grid: dict id -> (data, first trace)."""
    out = {}
    for full in stream:
        if full.id not in out:   # every channel gets a row, even with no data in the window
            out[full.id] = (np.full(n, np.nan), np.zeros(n, int), full)
        # only the analysis window, plus a margin for the filters' edges
        pad = (4 * DELAY_HALF_LENGTH + 10) / min(fs, full.stats.sampling_rate) + 1.0
        tr = full.slice(t0 - pad, t0 + (n - 1) / fs + pad)
        if tr.stats.npts == 0:
            continue
        x = _as_float(tr.data)
        source = getattr(tr.stats, "bayescal_source", tr.id)
        if np.isnan(x).any() and not np.ma.isMaskedArray(tr.data):
            warnings.warn(f"{source}: channel {tr.id} holds NaN samples; they are treated as gaps",
                          InputWarning, stacklevel=3)
        x = _mask_clipped(x, tr.id, source)
        x = _resample(x, tr.stats.sampling_rate, fs)
        grid, count, _ = out[tr.id]
        _place(grid, count, tr, x, fs, t0)
    return {tid: (g, t) for tid, (g, c, t) in out.items()}


def _stream_files(stream, default):
    files = sorted({getattr(tr.stats, "bayescal_source", "") for tr in stream} - {""})
    return ", ".join(files) if files else default


def _span(st):
    """The time every channel of ``st`` covers: its latest start and earliest end."""
    ids = {tr.id for tr in st}
    first = max(min(tr.stats.starttime for tr in st if tr.id == i) for i in ids)
    last = min(max(tr.stats.endtime for tr in st if tr.id == i) for i in ids)
    return first, last


def align_sensors(streams, inventories, sources=None, start=None, end=None, fs=None):
    """Bring the streams of n sensors onto one time grid and read their metadata.

    ``streams``, ``inventories``: one ObsPy Stream and Inventory per sensor;
    ``sources`` names them in messages. The common rate is the lowest sampling
    rate of all channels (or ``fs``); the grid starts at the latest channel
    start (or ``start``) and ends at the earliest channel end (or ``end``).
    Returns ``(sides, fs, starttime)``, one :class:`Side` per sensor, with NaN
    wherever a channel has no valid sample.
    """
    streams, inventories = list(streams), list(inventories)
    if len(streams) != len(inventories):
        raise InputError(f"{len(streams)} waveform inputs but {len(inventories)} metadata inputs")
    sources = list(sources) if sources is not None else \
        [f"sensor {i + 1}" for i in range(len(streams))]
    for st, source in zip(streams, sources):
        if len(st) == 0:
            raise InputError(f"{source}: no traces")
    fs = float(fs or min(tr.stats.sampling_rate for st in streams for tr in st))
    if start is not None and end is not None and start >= end:
        raise InputError(f"--start {start} is not before --end {end}")
    spans = [_span(st) for st in streams]
    files = [_stream_files(st, src) for st, src in zip(streams, sources)]
    t0, t1 = max(s[0] for s in spans), min(s[1] for s in spans)
    if t1 <= t0:
        named = [f"{f} ({a} - {b})" for f, (a, b) in zip(files, spans)]
        raise InputError(f"{', '.join(named[:-1])} and {named[-1]} do not overlap in time")
    if start is not None:
        t0 = max(t0, start)
    if end is not None:
        t1 = min(t1, end)
    if t1 <= t0:
        raise InputError(f"the window --start {start or '-'} --end {end or '-'} lies outside "
                         f"the common time of the recordings ({max(s[0] for s in spans)} - "
                         f"{min(s[1] for s in spans)}; {' and '.join(files)})")
    n = int(np.floor((t1 - t0) * fs + 1e-6)) + 1
    sides = []
    for st, inv, source in zip(streams, inventories, sources):
        gridded = _grid_stream(st, fs, t0, n)
        ids, data, vecs, resps, azs, dips, srcs = [], [], [], [], [], [], []
        for tid, (x, tr) in gridded.items():
            file = getattr(tr.stats, "bayescal_source", source)
            ch, az, dip = channel_meta(inv, tr, source)
            _check_channel(x, tid, file)
            ids.append(tid)
            data.append(x)
            vecs.append(unit_vector(az, dip))
            resps.append(ch.response)
            azs.append(az)
            dips.append(dip)
            srcs.append(file)
        sides.append(Side(ids=ids, data=np.array(data), vectors=np.array(vecs), responses=resps,
                          azimuths=azs, dips=dips, source=source, sources=srcs))
    return sides, fs, t0


def align(sut, sut_inventory, ref, ref_inventory, *, sut_source="SUT", ref_source="reference",
          start=None, end=None, fs=None):
    """Bring both streams onto one time grid and read their metadata
    (:func:`align_sensors` for a SUT and a reference).

    Returns ``(sut_side, ref_side, fs, starttime)`` with NaN wherever a
    channel has no valid sample.
    """
    (s, r), fs, t0 = align_sensors([sut, ref], [sut_inventory, ref_inventory],
                                   [sut_source, ref_source], start, end, fs)
    return s, r, fs, t0
