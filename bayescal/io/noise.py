"""Files -> aligned sensors -> cross-spectra -> self-noise of co-located sensors.

The shell around :mod:`bayescal.core.selfnoise.sleeman`, reusing the calibration
pipeline's pieces:

* :func:`.read.read_waveforms` reads one recording per sensor and
  :func:`.inventory.load_inventory` its metadata, as ``bayescal fit`` does
  (StationXML, RESP, GSE2 poles and zeros, or ``flat``);
* :func:`.align.align_sensors` puts every channel of every sensor on one time
  grid at the lowest sampling rate (anti-alias resampling, fractional-delay
  alignment, gap, clip and dead-channel checks);
* channels are grouped by component (Z, N, E: the axis nearest the
  StationXML azimuth and dip), one channel per sensor per group; a
  component seen by fewer than three sensors is skipped (and said so);
* :func:`bayescal.core.spectra.welch.cross_spectra` removes every response per
  gap-free run (to ground velocity), cuts Hann segments (50 % overlap) and
  sums the cross-spectral matrix per log-spaced band and per segment;
* :func:`bayescal.core.selfnoise.sleeman.acceleration_band_matrices` turns them into
  acceleration PSD matrices and :func:`bayescal.core.selfnoise.sleeman.estimate_self_noise`
  gives the estimates and their 90 % intervals, per band and as means over
  a few period bands (:data:`PERIOD_EDGES_S`); an interval that reaches
  zero power is below resolution: its upper bound is the result.

Horizontal components are only valid when the sensors are aligned with each
other: a misorientation leaks the other horizontal's ground motion into the
estimate (not corrected here). :func:`to_json` is the ``bayescal.noise/1``
document; figures are drawn by :mod:`bayescal.report.noise`.
"""
from __future__ import annotations

import json
import math
import os
from dataclasses import dataclass, field

import numpy as np

from ..core.selfnoise import (SelfNoise, acceleration_band_matrices, below_resolution, db,
                              estimate_self_noise, period_band_weights)
from ..core.spectra import band_dof, cross_spectra
from ..errors import InputError
from .read import read_waveforms
from .align import Side, align_sensors

SCHEMA = "bayescal.noise/1"
#: Bands per decade of the self-noise curves (merged where fewer than MIN_BINS bins).
BANDS_PER_DECADE = 16
MIN_BINS = 4
#: Default longest period (s) and upper frequency as a fraction of Nyquist
#: (digitizer FIR roll-off beyond, absent from nominal responses).
LONGEST_PERIOD = 100.0
NYQUIST_FRACTION = 0.8
#: Default allowance (rad rms per sensor and horizontal direction) for
#: differences between the sensors' sensitive axes (see
#: :func:`bayescal.core.selfnoise.sleeman.wishart_interval`): a levelling tolerance,
#: an assumption, not a measurement.
AXIS_MISMATCH = 1e-3
#: Components in output order; index = position in the NED unit vector.
COMPONENTS = "NEZ"
#: Period edges (s) of the period bands summarised on the console and in
#: noise.json's ``period_bands`` (half decades).
PERIOD_EDGES_S = (0.01, 0.03, 0.1, 0.3, 1.0, 3.0, 10.0, 30.0, 100.0, 300.0, 1000.0)


@dataclass
class ComponentNoise:
    """Self-noise of one component (Z, N or E) of the sensors."""

    component: str
    ids: list
    estimate: SelfNoise                # PSD in (m/s^2)^2/Hz
    nperseg: int
    n_segments: int
    fraction_used: float
    band_hz: tuple
    matrices: np.ndarray = None        # (B, n, n) acceleration PSD matrices
    period_bands: SelfNoise = None     # means over the period bands
    period_ranges: list = field(default_factory=list)   # (shortest, longest) s per band


@dataclass
class NoiseResult:
    """Self-noise of every component recorded by three or more sensors."""

    components: list
    fs: float
    starttime: str
    endtime: str
    files: list
    meta: dict = field(default_factory=dict)

    def by_id(self):
        """SEED id -> (component, index) for every channel estimated."""
        return {cid: (c, i) for c in self.components for i, cid in enumerate(c.ids)}


def component_of(vector):
    """'N', 'E' or 'Z': the axis nearest a channel's unit vector (NED)."""
    return COMPONENTS[int(np.argmax(np.abs(np.asarray(vector, float))))]


def group_components(sides):
    """``(groups, skipped)``: component -> list of (sensor index, channel
    index), sensors in input order; ``groups`` holds the components seen by
    three or more sensors (in the order Z, N, E), ``skipped`` the others."""
    groups = {}
    for s, side in enumerate(sides):
        seen = {}
        for c, vec in enumerate(side.vectors):
            comp = component_of(vec)
            if comp in seen:
                raise InputError(f"{side.sources[c] if side.sources else side.source}: channels "
                                 f"{side.ids[seen[comp]]} and {side.ids[c]} both point along "
                                 f"{comp}; give one channel per component and sensor")
            seen[comp] = c
            groups.setdefault(comp, []).append((s, c))
    keep = {k: v for k, v in groups.items() if len(v) >= 3}
    skipped = {k: v for k, v in groups.items() if len(v) < 3}
    return dict(sorted(keep.items(), key=lambda kv: "ZNE".index(kv[0]))), skipped


def default_band(fs, n_samples):
    """(fmin, fmax): periods up to ``LONGEST_PERIOD`` s (or a 40th of the
    record), up to ``NYQUIST_FRACTION`` of Nyquist."""
    fmin = max(1.0 / LONGEST_PERIOD, 40.0 * fs / n_samples)
    return fmin, NYQUIST_FRACTION * fs / 2


def _check_distinct(data, sources, ids):
    """Two sensors with identical samples (the same file given twice) leave
    nothing to separate noise from signal."""
    both = np.isfinite(data).all(axis=0)
    for a in range(len(ids)):
        for b in range(a + 1, len(ids)):
            if np.array_equal(data[a, both], data[b, both]):
                raise InputError(f"{sources[b]}: channel {ids[b]} holds the same samples as "
                                 f"{ids[a]} ({sources[a]}); give three different sensors")


def self_noise_spectra(spectra, level=0.9, n_boot=1000, seed=0, method="wishart", block=4,
                       axis_mismatch=AXIS_MISMATCH, period_edges=None):
    """:class:`bayescal.core.selfnoise.sleeman.SelfNoise` (acceleration PSD) of the
    channels of ``spectra``: one component of n >= 3 sensors, in velocity.
    Also returns the (B, n, n) acceleration matrices. With ``period_edges``
    (s) returns a third and a fourth item: the estimates averaged over those
    period bands (:func:`bayescal.core.selfnoise.sleeman.period_band_weights`) and
    the bands' (shortest, longest) periods."""
    C, fc = acceleration_band_matrices(spectra)
    dof = band_dof(spectra)
    kw = dict(level=level, n_boot=n_boot, seed=seed, per_segment=spectra.per_segment,
              method=method, block=block, axis_mismatch=axis_mismatch, ids=spectra.sut_ids)
    est = estimate_self_noise(C, dof, fc, **kw)
    if period_edges is None:
        return est, C
    edges = spectra.band_edges
    W, ranges = period_band_weights(fc, period_edges, (1.0 / edges[-1], 1.0 / edges[0]))
    bands = estimate_self_noise(C, dof, fc, combine=W, **kw) if len(ranges) else None
    return est, C, bands, ranges


def self_noise_streams(streams, inventories, *, sources=None, band=None, nperseg=None, start=None,
                       end=None, level=0.9, n_boot=1000, seed=0, method="wishart",
                       axis_mismatch=AXIS_MISMATCH, bands_per_decade=BANDS_PER_DECADE,
                       progress=None):
    """Self-noise of every component seen by three or more of the sensors.

    ``streams``/``inventories``: one ObsPy Stream and Inventory per sensor;
    ``sources`` their names (files) for messages. ``band`` (fmin, fmax) Hz,
    default :func:`default_band`. ``method`` "wishart" (default) or "block";
    ``axis_mismatch`` rad rms (0: sampling error only). ``progress``: a
    callable taking one line of text. Returns a :class:`NoiseResult`.
    """
    say = progress or (lambda msg: None)
    if len(streams) < 3:
        raise InputError(f"self-noise needs recordings of at least three co-located sensors, "
                         f"got {len(streams)}")
    sides, fs, t0 = align_sensors(streams, inventories, sources, start, end)
    n_samples = sides[0].data.shape[1]
    band = tuple(float(b) for b in (band or default_band(fs, n_samples)))
    if not (np.all(np.isfinite(band)) and 0 < band[0] < band[1]):
        raise InputError(f"band {band[0]:g}-{band[1]:g} Hz is not a positive interval")
    groups, skipped = group_components(sides)
    if not groups:
        raise InputError("no component is recorded by three or more of the sensors: self-noise "
                         "needs three co-located channels of one component")
    for comp, members in skipped.items():
        say(f"component {comp}: only {len(members)} sensor(s), not estimated")
    out = []
    for comp, members in groups.items():
        data = np.array([sides[s].data[c] for s, c in members])
        ids = [sides[s].ids[c] for s, c in members]
        _check_distinct(data, [sides[s].sources[c] for s, c in members], ids)
        side = Side(ids=ids, data=data, vectors=np.zeros((len(ids), 3)),
                    responses=[sides[s].responses[c] for s, c in members], azimuths=[], dips=[])
        spectra = cross_spectra(data, np.empty((0, n_samples)), fs, side.response_fn(), None,
                                band, nperseg=nperseg, bands_per_decade=bands_per_decade,
                                min_bins=MIN_BINS, sut_ids=ids)
        say(f"component {comp}: {', '.join(ids)}; {spectra.n_segments} segments of "
            f"{spectra.nperseg / fs:.0f} s ({100 * spectra.fraction_used:.0f} % of the record)")
        est, C, bands, ranges = self_noise_spectra(spectra, level, n_boot, seed, method,
                                                   axis_mismatch=axis_mismatch,
                                                   period_edges=PERIOD_EDGES_S)
        out.append(ComponentNoise(comp, ids, est, spectra.nperseg, spectra.n_segments,
                                  spectra.fraction_used, band, C, bands, ranges))
    t1 = t0 + (n_samples - 1) / fs
    return NoiseResult(out, fs, str(t0), str(t1), list(sources or []),
                       meta={"band_hz": list(band), "method": method, "level": level,
                             "axis_mismatch_rad": axis_mismatch if method == "wishart" else None,
                             "n_boot": n_boot, "seed": seed,
                             "skipped_components": sorted(skipped)})


def self_noise_files(data_paths, xml_paths, **kw):
    """:func:`self_noise_streams` from one waveform file and one metadata entry
    per sensor (same order). Each entry is what ``bayescal fit`` takes (see
    :func:`.inventory.load_inventory`): a StationXML, RESP or GSE2
    poles-and-zeros file, an ObsPy Inventory, or ``"flat"`` (a flat velocity
    response of 1 count per m/s: that sensor's self-noise is then in counts
    referred through that assumed response, not in ground units; its ids are
    listed in ``meta["flat_metadata"]``)."""
    from .inventory import load_inventory

    data_paths, xml_paths = list(data_paths), list(xml_paths)
    if len(data_paths) != len(xml_paths):
        raise InputError(f"{len(data_paths)} waveform files but {len(xml_paths)} StationXML "
                         "(or RESP, GSE2, flat) entries: give one per sensor, in the same order")
    if len(data_paths) < 3:
        raise InputError(f"{', '.join(map(os.fspath, data_paths))}: self-noise needs recordings "
                         f"of at least three co-located sensors, got {len(data_paths)}")
    streams = [read_waveforms(p, side="waveform") for p in data_paths]
    invs = [load_inventory(x if hasattr(x, "networks") else os.fspath(x), st)
            for x, st in zip(xml_paths, streams)]
    flat = sorted({tr.id for x, st in zip(xml_paths, streams)
                   if isinstance(x, str) and x.lower() == "flat" for tr in st})
    result = self_noise_streams(streams, invs, sources=[os.fspath(p) for p in data_paths], **kw)
    estimated = set(result.by_id())
    result.meta["flat_metadata"] = [cid for cid in flat if cid in estimated]
    return result


# --- output ---------------------------------------------------------------------------------
def _num(x, nd=2):
    x = float(x)
    return round(x, nd) if math.isfinite(x) else None


def _nums(a, nd=2):
    return [_num(v, nd) for v in a]


def to_json(result):
    """The ``bayescal.noise/1`` document.

    ``sensors``: per SEED id, by increasing period, ``period_s``, the
    self-noise ``psd_db`` (dB re 1 (m/s^2)^2/Hz; null where the estimate is
    not positive) and ``ci90_db`` = [lower, upper] (null where unbounded: a
    lower bound at zero power), ``below_resolution`` (true where that
    lower bound is zero power: the upper bound is the result), plus
    ``recorded_psd_db`` (the channel's whole PSD), ``pair_range_db`` (min
    and max over the pairs of other sensors), ``dof``, ``component``,
    ``others`` and ``period_bands``: the same over a few period bands
    (means of the bands' matrices; see :func:`period_band_summary`).
    ``meta``: window, files, method; ``flat_metadata`` lists the channels
    whose response was given as ``flat`` (their numbers are not in ground
    units).
    """
    sensors = {}
    for comp in result.components:
        e = comp.estimate
        order = np.argsort(e.period_s)
        psd, ci = e.psd_db()[:, order], e.ci_db()[:, :, order]
        amb = db(e.signal)[:, order]
        pr = db(e.pair_range)[:, order]
        below = below_resolution(e.lo)[:, order]
        bands = period_band_summary(comp)
        for i, cid in enumerate(comp.ids):
            sensors[cid] = {
                "period_s": _nums(e.period_s[order], 5),
                "psd_db": _nums(psd[i]),
                f"ci{round(100 * e.level)}_db": [_nums(ci[0, i]), _nums(ci[1, i])],
                "below_resolution": [bool(b) for b in below[i]],
                "recorded_psd_db": _nums(amb[i]),
                "pair_range_db": [_nums(pr[i, :, 0]), _nums(pr[i, :, 1])],
                "dof": _nums(e.dof[order], 1),
                "component": comp.component,
                "others": [o for o in comp.ids if o != cid],
                "period_bands": bands.get(cid, []),
            }
    interval = ("basic bootstrap on linear power, parametric complex Wishart with the window's "
                "effective degrees of freedom" if result.meta.get("method") == "wishart"
                else "basic moving-block bootstrap over segments")
    return {"schema": SCHEMA, "sensors": sensors,
            "meta": {"fs_hz": result.fs, "start": result.starttime, "end": result.endtime,
                     "files": result.files, "units": "dB re 1 (m/s^2)^2/Hz",
                     "estimator": "Sleeman et al. (2006), real part; median over pairs of "
                                  "other sensors when more than three",
                     "interval": interval, **result.meta,
                     "segments": {c.component: {"nperseg": c.nperseg, "n_segments": c.n_segments,
                                                "fraction_used": round(c.fraction_used, 3)}
                                  for c in result.components}}}


def period_band_summary(comp):
    """SEED id -> list, by increasing period, of the period-band means of one
    :class:`ComponentNoise`: ``period_s`` [shortest, longest], ``psd_db``
    (null where not positive), ``ci<level>_db`` [lower (null: zero power),
    upper], ``below_resolution`` (the interval reaches zero power: the
    self-noise is below what the data resolve, and only the upper bound is a
    result) and ``recorded_psd_db``."""
    e = comp.period_bands
    if e is None:
        return {}
    key = f"ci{round(100 * e.level)}_db"
    psd, ci, rec = e.psd_db(), e.ci_db(), db(e.signal)
    below = below_resolution(e.lo)
    order = np.argsort([r[0] for r in comp.period_ranges])
    out = {}
    for i, cid in enumerate(comp.ids):
        out[cid] = [{"period_s": [_num(comp.period_ranges[g][0], 4),
                                  _num(comp.period_ranges[g][1], 4)],
                     "psd_db": _num(psd[i, g]),
                     key: [_num(ci[0, i, g]), _num(ci[1, i, g])],
                     "below_resolution": bool(below[i, g]),
                     "recorded_psd_db": _num(rec[i, g])}
                    for g in order]
    return out


def write_json(result, folder):
    """Write ``noise.json`` into ``folder``; returns its path."""
    path = os.path.join(folder, "noise.json")
    with open(path, "w") as fh:
        json.dump(to_json(result), fh, indent=1)
    return path
