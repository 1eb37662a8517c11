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
  samples are gaps, clipped samples warn and are treated as gaps; a trace
  whose sampling rate is not a positive number is an error;
* metadata checks: every value of a channel the fit uses (azimuth, dip,
  sample rate, sensitivity, stage gains, poles and zeros, normalisation,
  decimation, coefficients) must be a finite number in range, as written in
  the file and as read (:mod:`bayescal.io.validate`), and the response must
  evaluate; a channel that fails is named with the file and the value.

Errors are raised as :class:`bayescal.errors.InputError` with one sentence naming the file
and the problem; the command line turns them into a message and exit code 2.
"""
from __future__ import annotations

import os
import re

import numpy as np

from ..errors import InputError


#: Orientation implied by a SEED component code when StationXML has none.
CODE_ORIENTATION = {"N": (0.0, 0.0), "E": (90.0, 0.0), "Z": (0.0, -90.0)}


def _paths(paths):
    if isinstance(paths, (str, os.PathLike)):
        return [os.fspath(paths)]
    return [os.fspath(p) for p in paths]


def obspy_reason(exc):
    """Why ObsPy could not read a file, in words: its message's first line
    ("none of its formats" for ObsPy's "Unknown format"), never only the
    exception's class."""
    text = (str(exc).strip().splitlines() or [""])[0]
    if not text or text.startswith("Unknown format"):
        return "it recognises none of its formats in it"
    return text[:160]


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
                             f"({obspy_reason(exc)})") from None
        if len(st) == 0:
            raise InputError(f"{path}: the file holds no traces")
        for tr in st:
            sr = tr.stats.sampling_rate
            if not (np.isfinite(sr) and sr > 0):
                raise InputError(f"{path}: trace {tr.id} has sampling rate {sr!r}, not a positive "
                                 "number")
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
        inv = paz_inventory(stream, zeros=zeros, poles=poles, gain=gain, normalize=False,
                            orientations=unknown,
                            note=f"the response is the GSE2 poles and zeros of {path} (read "
                                 "as ObsPy's rel_calib_stack reads them: velocity, gain "
                                 f"{gain:g} counts per m/s, A0 = 1), applied to every channel")
        return _mark_read(inv, path, {})
    import warnings

    from .validate import scan_stationxml
    try:
        with warnings.catch_warnings():
            # numbers ObsPy cannot convert are reported by the checks, per channel
            warnings.filterwarnings("ignore", message=".*(could not be converted|value of NaN)")
            if kind == "RESP":
                inv = obspy.read_inventory(path, format="RESP")
            else:
                inv = obspy.read_inventory(path)
    except Exception as exc:
        what = "RESP" if kind == "RESP" else "StationXML (or other metadata)"
        raise InputError(f"{path}: not a {what} file ObsPy can read "
                         f"({obspy_reason(exc)})") from None
    return _mark_read(inv, path, scan_stationxml(path) if kind is None else {})


def _mark_read(inventory, path, problems):
    """Keep on ``inventory`` the file it was read from and the numbers of
    its channel epochs that are not finite as written (see
    :func:`channel_meta`)."""
    inventory.bayescal_read = {"path": path, "problems": problems, "checked": set()}
    return inventory


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


def paz_inventory(stream, zeros=(), poles=(), gain=1.0, norm_freq=1.0, *, orientations=None,
                  normalize=True, input_units="M/S", note=None):
    """An Inventory for every channel of ``stream`` with one poles-and-zeros
    stage (rad/s; ``gain`` counts per ``input_units`` at ``norm_freq``).

    ``orientations`` maps channel codes to (azimuth, dip); channels not in it
    get :func:`orientation_from_code`. With no poles and zeros this is a flat
    velocity response: the way to run sensors that are flat in the band and
    have no StationXML (see docs/validation/real_data.md). Every channel carries a
    Comment (:data:`PLACEHOLDER_NOTE`, then ``note``) marking what is invented.
    """
    from obspy import UTCDateTime
    from obspy.core.inventory import Channel, Inventory, Network, Response, Station
    from obspy.core.inventory.util import Comment

    from ..core.response import normalization_factor

    zeros, poles = list(zeros), list(poles)
    a0 = normalization_factor(zeros, poles, norm_freq) if normalize else 1.0
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
def _check_values(inventory, ch, tr, source):
    """Raise :class:`InputError` naming the metadata file when a value of
    channel ``ch`` that the fit uses is not a finite number in range
    (:mod:`bayescal.io.validate`)."""
    from .validate import channel_problem, epoch_key

    info = getattr(inventory, "bayescal_read", None) or {}
    key = epoch_key(tr.id, ch.start_date)
    if key in info.get("checked", ()):
        return
    problem = (info.get("problems", {}).get(key)
               or channel_problem(ch, tr.stats.sampling_rate))
    if problem:
        raise InputError(f"{info.get('path', source)}: channel {tr.id}: {problem}")
    if "checked" in info:
        info["checked"].add(key)


def channel_meta(inventory, tr, source):
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
    _check_values(inventory, ch, tr, source)
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
