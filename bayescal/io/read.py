"""Recordings in: waveform files and StationXML to aligned sample arrays,
channel axes and responses.

What real recordings need, and what this module does about it:

* any waveform format ObsPy reads, several files per side
  (:func:`read_waveforms`); StationXML, RESP or GSE2 poles and zeros, recognised
  by content (:func:`read_metadata`);
* gaps and overlaps: every trace is placed on one common time grid; missing
  samples, and overlaps whose data disagree, become NaN, so the spectra drop
  every segment that touches them;
* different start times and sub-sample time offsets: a windowed-sinc
  fractional delay puts each trace exactly on the grid (offsets under 1 % of a
  sample are rounded);
* different sampling rates: every trace is brought to the lowest rate with
  :func:`scipy.signal.resample_poly` (a Kaiser-windowed FIR anti-alias
  filter); the filter's edge samples are set to NaN;
* channels are identified by their StationXML azimuth and dip; when those
  are missing, from the SEED component code (N/E/Z; 1/2 need StationXML);
* data checks: a channel with no finite sample or all zeros is an error, NaN
  samples are gaps, clipped samples warn and are treated as gaps.

Errors are raised as :class:`InputError` with one sentence naming the file
and the problem; the command line turns them into a message and exit code 2.
"""
from __future__ import annotations

import os
import re
import warnings
from dataclasses import dataclass, field
from fractions import Fraction

import numpy as np

from ..core.geometry import unit_vector
from ..core.response import ResponseError, TwoPoleFamily, evaluate_velocity_response

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
#: Orientation implied by a SEED component code when StationXML has none.
CODE_ORIENTATION = {"N": (0.0, 0.0), "E": (90.0, 0.0), "Z": (0.0, -90.0)}


class InputError(ValueError):
    """Bad input data or metadata; the message names the source and problem."""


class InputWarning(UserWarning):
    """Suspicious input (clipping, NaN samples) that does not stop the fit."""


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
        """Callable freqs -> (n, F) complex velocity responses."""
        return lambda f: np.array([evaluate_velocity_response(r, f) for r in self.responses])

    def families(self):
        """Per channel the :class:`TwoPoleFamily` of its response, or None
        when the first stage is not a two-pole poles-and-zeros stage."""
        out = []
        for r in self.responses:
            try:
                out.append(TwoPoleFamily.from_response(r))
            except ResponseError:
                out.append(None)
        return out

    @property
    def fraction_finite(self):
        """Fraction of grid samples present on every channel at once."""
        return float(np.mean(np.all(np.isfinite(self.data), axis=0)))


# --- reading files -----------------------------------------------------------
def _paths(paths):
    if isinstance(paths, (str, os.PathLike)):
        return [os.fspath(paths)]
    return [os.fspath(p) for p in paths]


def read_waveforms(paths, side="waveform"):
    """Read one or several waveform files (any format ObsPy reads) into one
    Stream. Each trace keeps the file it came from in
    ``trace.stats.bayescal_source``."""
    import obspy

    paths = _paths(paths)
    if not paths:
        raise InputError(f"no {side} file given")
    out = obspy.Stream()
    for path in paths:
        if not os.path.isfile(path):
            raise InputError(f"{path}: {side} file not found")
        try:
            st = obspy.read(path)
        except Exception as exc:  # ObsPy raises many types for unreadable files
            raise InputError(f"{path}: not a waveform file ObsPy can read "
                             f"({type(exc).__name__}: {str(exc).splitlines()[0] if str(exc) else ''})"
                             ) from None
        if len(st) == 0:
            raise InputError(f"{path}: the file holds no traces")
        for tr in st:
            tr.stats.bayescal_source = path
        out += st
    return out


def metadata_format(path):
    """What kind of metadata file ``path`` is, from its first lines:
    ``"GSE2"`` (a ``CAL1 ... PAZ`` poles-and-zeros file), ``"RESP"`` (SEED
    RESP text, blockettes 050-062) or ``None`` (left to ObsPy: StationXML,
    dataless SEED, SC3ML, ...)."""
    try:
        with open(path, "rb") as fh:
            head = fh.read(20000).decode("latin-1")
    except OSError:
        return None
    lines = [ln for ln in head.splitlines() if ln.strip()]
    if lines and lines[0].startswith("CAL1") and lines[0][31:34] == "PAZ":
        return "GSE2"
    if re.search(r"^B0(5[0-9]|6[0-2])F\d\d", head, re.MULTILINE):
        return "RESP"
    return None


def read_metadata(path, side="StationXML", stream=None):
    """An ObsPy Inventory from a metadata file, recognised by its content:

    * StationXML (or any other inventory format ObsPy reads);
    * SEED RESP text (through ``obspy.read_inventory(format="RESP")``; RESP
      holds no orientation, so the channel codes give it: N/1 north, E/2
      east, Z/3 vertical);
    * a GSE2 ``CAL1 ... PAZ`` poles-and-zeros file (:func:`read_gse2_paz`),
      which names no channel: it is applied to every channel of ``stream``
      (required then) as :func:`paz_inventory` does, read the way ObsPy's
      ``rel_calib_stack`` reads it (a velocity response whose gain, counts
      per m/s, is a plain factor: A0 = 1), orientations from the channel codes,
      and marked as placeholder metadata.
    """
    import obspy

    path = os.fspath(path)
    if not os.path.isfile(path):
        raise InputError(f"{path}: {side} file not found")
    kind = metadata_format(path)
    if kind == "GSE2":
        if stream is None or len(stream) == 0:
            raise InputError(f"{path}: a GSE2 poles-and-zeros file names no channel; it can "
                             "only be used beside the recordings it describes")
        poles, zeros, gain = read_gse2_paz(path)
        unknown = {}   # codes that say no orientation (coil inputs, U/V/W): none written
        for tr in stream:
            try:
                orientation_from_code(tr.stats.channel)
            except InputError:
                unknown[tr.stats.channel] = (None, None)
        return paz_inventory(stream, zeros=zeros, poles=poles, gain=gain, normalize=False,
                             orientations=unknown,
                             note=f"the response is the GSE2 poles and zeros of {path} (read "
                                  "as ObsPy's rel_calib_stack reads them: velocity, gain "
                                  f"{gain:g} counts per m/s, A0 = 1), applied to every channel")
    try:
        if kind == "RESP":
            return obspy.read_inventory(path, format="RESP")
        return obspy.read_inventory(path)
    except Exception as exc:
        what = "RESP" if kind == "RESP" else "StationXML (or other metadata)"
        raise InputError(f"{path}: not a {what} file ObsPy can read "
                         f"({type(exc).__name__})") from None


def read_gse2_paz(path):
    """Poles, zeros (rad/s) and gain of a GSE2 ``CAL1 ... PAZ`` file, such as
    the ``STS2_simp.cal`` that ObsPy's ``rel_calib_stack`` reads."""
    from obspy.io.gse2.paz import read_paz

    try:
        return read_paz(os.fspath(path))
    except Exception as exc:
        raise InputError(f"{path}: not a GSE2 poles-and-zeros file ({exc})") from None


# --- metadata builders ---------------------------------------------------------
def orientation_from_code(channel_code):
    """(azimuth, dip) implied by a SEED channel code's last letter: N, E, Z;
    and, as the usual convention when nothing else is known, 1 = north,
    2 = east, 3 = vertical. Raises :class:`InputError` for other codes."""
    comp = channel_code[-1:].upper()
    comp = {"1": "N", "2": "E", "3": "Z"}.get(comp, comp)
    if comp not in CODE_ORIENTATION:
        raise InputError(f"channel {channel_code}: cannot tell its orientation from the code")
    return CODE_ORIENTATION[comp]


#: Comment on every channel bayescal invents (coordinates and dates unknown).
PLACEHOLDER_NOTE = ("placeholder metadata written by bayescal, not measured: latitude, "
                    "longitude, elevation and depth (0) and start date (1970-01-01) are "
                    "unknown; orientation is nominal from the channel code")


def paz_inventory(stream, zeros=(), poles=(), gain=1.0, norm_freq=1.0, orientations=None,
                  normalize=True, input_units="M/S", note=None):
    """An Inventory for every channel of ``stream`` with one poles-and-zeros
    stage (rad/s; ``gain`` counts per ``input_units`` at ``norm_freq``).

    ``orientations`` maps channel codes to (azimuth, dip); channels not in it
    get :func:`orientation_from_code`. With no poles and zeros this is a flat
    velocity response: the way to run sensors that are flat in the band and
    have no StationXML (see docs/real_data.md). Every channel carries a
    Comment (:data:`PLACEHOLDER_NOTE`, then ``note``) marking what is invented.
    """
    from obspy import UTCDateTime
    from obspy.core.inventory import Channel, Inventory, Network, Response, Station
    from obspy.core.inventory.util import Comment

    zeros, poles = list(zeros), list(poles)
    s = 2j * np.pi * norm_freq
    paz = np.prod([s - z for z in zeros]) / np.prod([s - p for p in poles]) if (zeros or poles) \
        else 1.0
    a0 = float(1.0 / abs(paz)) if normalize else 1.0
    nets = {}
    for tr in stream:
        st = tr.stats
        code = st.channel
        az, dip = (orientations or {}).get(code) or orientation_from_code(code)
        resp = Response.from_paz(zeros, poles, stage_gain=float(gain),
                                 stage_gain_frequency=norm_freq, input_units=input_units,
                                 output_units="COUNTS", normalization_frequency=norm_freq,
                                 normalization_factor=a0)
        net = nets.setdefault(st.network, {})
        sta = net.setdefault(st.station, [])
        if any(c.location_code == st.location and c.code == code for c in sta):
            continue
        sta.append(Channel(code=code, location_code=st.location, latitude=0.0, longitude=0.0,
                           elevation=0.0, depth=0.0,
                           azimuth=None if az is None else float(az),
                           dip=None if dip is None else float(dip),
                           sample_rate=st.sampling_rate, response=resp,
                           start_date=UTCDateTime(1970, 1, 1),
                           comments=[Comment(value=PLACEHOLDER_NOTE + (f"; {note}" if note
                                                                       else ""),
                                             subject="bayescal placeholder")]))
    networks = [Network(code=n, stations=[Station(code=s, latitude=0.0, longitude=0.0,
                                                  elevation=0.0, channels=chans)
                                          for s, chans in stas.items()])
                for n, stas in nets.items()]
    return Inventory(networks=networks, source="bayescal nominal metadata")


def flat_inventory(stream, orientations=None, gain=1.0):
    """Flat velocity response (``gain`` counts per m/s) and nominal
    orientations for every channel of ``stream`` (see :func:`paz_inventory`)."""
    return paz_inventory(stream, gain=gain, orientations=orientations,
                         note=f"the response is an assumed flat {gain:g} counts per m/s "
                              "('flat' given for the StationXML), not a measured one")


def two_pole_inventory(stream, period_s, damping, gain, norm_freq=1.0, orientations=None):
    """Nominal inventory of a velocity sensor: two zeros at the origin and a
    pendulum pole pair of natural period ``period_s`` and ``damping``, gain
    ``gain`` counts per m/s at ``norm_freq``."""
    w0 = 2 * np.pi / period_s
    re, im = -damping * w0, w0 * np.sqrt(max(1 - damping ** 2, 0.0))
    if damping < 1:
        poles = [complex(re, im), complex(re, -im)]
    else:
        r = w0 * np.sqrt(damping ** 2 - 1)
        poles = [complex(re + r, 0), complex(re - r, 0)]
    return paz_inventory(stream, zeros=[0j, 0j], poles=poles, gain=gain, norm_freq=norm_freq,
                         orientations=orientations)


# --- channel metadata ------------------------------------------------------------
def _channel_meta(inventory, tr, source):
    """The StationXML channel of trace ``tr`` and its (azimuth, dip)."""
    try:
        ch = inventory.select(network=tr.stats.network, station=tr.stats.station,
                              location=tr.stats.location, channel=tr.stats.channel,
                              time=tr.stats.starttime)[0][0][0]
    except IndexError:
        epochs = [c for n in inventory.select(network=tr.stats.network, station=tr.stats.station,
                                               location=tr.stats.location,
                                               channel=tr.stats.channel)
                  for s in n for c in s]
        if epochs:
            spans = "; ".join(f"{c.start_date} - {c.end_date or 'open'}" for c in epochs)
            raise InputError(f"{source}: channel {tr.id} is in the StationXML, but no epoch "
                             f"covers the data starting {tr.stats.starttime} (epochs: {spans})"
                             ) from None
        raise InputError(f"{source}: channel {tr.id} is not in the StationXML") from None
    az, dip = ch.azimuth, ch.dip
    if az is None or dip is None:
        try:
            az, dip = orientation_from_code(tr.stats.channel)
        except InputError:
            raise InputError(f"{source}: channel {tr.id} has no azimuth/dip in the StationXML "
                             "and its code does not say its orientation") from None
    if ch.response is None or not ch.response.response_stages:
        raise InputError(f"{source}: channel {tr.id} has no response in the StationXML")
    return ch, float(az), float(dip)


# --- placing traces on the grid ------------------------------------------------------
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

    def span(st):
        ids = {tr.id for tr in st}
        first = max(min(tr.stats.starttime for tr in st if tr.id == i) for i in ids)
        last = min(max(tr.stats.endtime for tr in st if tr.id == i) for i in ids)
        return first, last

    if start is not None and end is not None and start >= end:
        raise InputError(f"--start {start} is not before --end {end}")
    spans = [span(st) for st in streams]
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
            ch, az, dip = _channel_meta(inv, tr, source)
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


def align(sut, sut_inventory, ref, ref_inventory, sut_source="SUT", ref_source="reference",
          start=None, end=None, fs=None):
    """Bring both streams onto one time grid and read their metadata
    (:func:`align_sensors` for a SUT and a reference).

    Returns ``(sut_side, ref_side, fs, starttime)`` with NaN wherever a
    channel has no valid sample.
    """
    (s, r), fs, t0 = align_sensors([sut, ref], [sut_inventory, ref_inventory],
                                   [sut_source, ref_source], start, end, fs)
    return s, r, fs, t0
