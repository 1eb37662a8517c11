"""A pair's record cut into consecutive windows, each fitted as ``bayescal fit`` fits one.

:func:`fit_windows` takes the two sensors' recordings once (ObsPy streams and
inventories, as :func:`bayescal.pair.workflow.calibrate` takes them), cuts
``[start, end)`` into windows of ``window`` seconds (a last window shorter
than that is not fitted) and runs the pair pipeline
(:func:`~bayescal.pair.workflow.calibrate`: prepare, fit, criticise, choose)
on each. Each fitted window keeps, per parameter (each channel's azimuth and
dip where estimated, its relative gain where fitted), the posterior's
median, 68 and 95 % intervals and samples. A window the pipeline refuses
(too little gap-free data, no coherence in the band: the errors of
:mod:`bayescal.errors`) is listed with its reason and skipped.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np


@dataclass(frozen=True)
class Window:
    """One window's fit: ``start`` and ``end`` (UTCDateTime), per parameter
    its summary (``median``, ``ci68``, ``ci95``) in ``values`` and its
    posterior samples in ``samples``, its sampler's ``convergence`` (a
    result's ``convergence`` entry), the band it fitted (``band_hz``,
    ``[fmin, fmax]``, and its bands' edges ``band_edges_hz``), each band's
    noise ``inflation`` in the fit kept, the record's inflation ``floor``
    when the windows were pooled (:mod:`bayescal.record.pooling`; None
    otherwise) and whether it was fitted again with it (``floored``); or
    the ``reason`` it was skipped."""

    start: object
    end: object
    values: dict = field(default_factory=dict)
    samples: dict = field(default_factory=dict, repr=False)
    reason: str | None = None
    convergence: dict = field(default_factory=dict, repr=False)
    band_hz: list | None = None
    band_edges_hz: tuple | None = field(default=None, repr=False)
    inflation: object = field(default=None, repr=False)
    floor: object = field(default=None, repr=False)
    floored: bool = False

    @property
    def fitted(self):
        """True when the window was fitted."""
        return self.reason is None


def window_edges(start, end, window):
    """``(t0, t1)`` of the consecutive windows of ``window`` seconds in
    ``[start, end)`` (UTCDateTime); a last window shorter than ``window`` is left out."""
    n = int(np.floor((end - start) / window + 1e-9))
    return [(start + k * window, start + (k + 1) * window) for k in range(n)]


def parameters(result):
    """Per parameter of a window's :class:`~bayescal.result.record.Result`:
    ``(summary, samples)``, named ``"<channel id>:azimuth_deg"``,
    ``":dip_deg"`` and ``":relative_gain"`` (those with a 95 % interval)."""
    from ..core.posterior import sampled_azimuth_dip
    az, dip = sampled_azimuth_dip(result.vectors)
    out = {}
    for k, cid in enumerate(result.channel_ids):
        entry = result.channels[cid]
        for name, draws in (("azimuth_deg", az[:, k]), ("dip_deg", dip[:, k])):
            if "ci95" in entry.get(name, {}) and entry[name].get("median") is not None:
                out[f"{cid}:{name}"] = (entry[name], draws)
        rel = (entry.get("response") or {}).get("relative_gain", {})
        if "ci95" in rel and cid in result.response:
            nominal = entry["nominal"]["gain"]
            out[f"{cid}:relative_gain"] = (rel, result.response[cid][:, 2] / nominal)
    return out


def recorded_span(ref, sut):
    """From the latest first sample to the earliest end over the channels of
    the two sides (each channel's traces taken together, gaps inside
    allowed). ``ref`` and ``sut`` are kept apart, so a channel of each with
    the same SEED id (two sensors written to separate files) counts twice."""
    spans = {}
    for side, traces in (("ref", ref), ("sut", sut)):
        for tr in traces:
            a, b = tr.stats.starttime, tr.stats.endtime + tr.stats.delta
            lo, hi = spans.get((side, tr.id), (a, b))
            spans[(side, tr.id)] = (min(lo, a), max(hi, b))
    return max(a for a, _ in spans.values()), min(b for _, b in spans.values())


def fit_window(pair, t0, t1, seed, **options):
    """One window's :class:`Window`; ``pair``: ``(ref, ref_xml, sut, sut_xml)``
    as :func:`~bayescal.pair.workflow.calibrate` takes them, ``options`` its
    other keywords."""
    from ..errors import FitError, InputError, ResponseError, SpectraError
    from ..pair import calibrate
    ref, ref_xml, sut, sut_xml = pair
    floor = options.get("inflation_floor")
    try:
        result = calibrate(ref=ref, ref_xml=ref_xml, sut=sut, sut_xml=sut_xml, start=t0, end=t1,
                           seed=seed, **options)
    except (InputError, SpectraError, FitError, ResponseError) as exc:
        return Window(t0, t1, reason=str(exc), floor=floor, floored=floor is not None)
    values, samples = {}, {}
    for name, (entry, draws) in parameters(result).items():
        values[name] = {k: entry[k] for k in ("median", "ci68", "ci95")}
        samples[name] = np.asarray(draws, float)
    band = result.meta.band_hz
    inflation = getattr(result.meta, "noise_inflation", None)
    edges = getattr(result.meta, "band_edges_hz", None)
    return Window(t0, t1, values=values, samples=samples,
                  convergence=result.convergence.summary(),
                  band_hz=[float(f) for f in band] if band is not None else None,
                  band_edges_hz=None if edges is None else tuple(float(f) for f in edges),
                  inflation=None if inflation is None else np.asarray(inflation, float).ravel(),
                  floor=floor, floored=floor is not None)


def fit_windows(*, ref, ref_xml, sut, sut_xml, start=None, end=None, window=600.0, seed=0,
                on_window=None, pool_inflation=False, **options):
    """Fit each window of a pair's record.

    Parameters
    ----------
    ref, ref_xml, sut, sut_xml : obspy.Stream; obspy.Inventory or "flat"
        The two sensors' recordings (read once) and metadata, as
        :func:`~bayescal.pair.workflow.calibrate` takes them.
    start, end : obspy.UTCDateTime or None
        The part of the record cut into windows (default: where both
        sensors record).
    window : float
        Each window's length in seconds.
    seed : int
        Window ``k`` is fitted with seed ``seed + k``.
    on_window : callable or None
        Called with ``(k, n, Window)`` after each fit (progress), again for
        a window fitted with the record's inflation floor.
    pool_inflation : bool
        Fit again, with the record's noise inflation as a floor, each
        window whose own inflation falls below it in some band
        (:mod:`bayescal.record.pooling`).
    **options
        Every other keyword of :func:`~bayescal.pair.workflow.calibrate`
        (``band``, ``fit_response``, ``diagnose``, ``transients``, ...).

    Returns
    -------
    list of Window, in time order (fitted and skipped).

    Raises
    ------
    InputError
        When ``[start, end)`` holds no whole window.
    """
    from ..errors import InputError
    first, last = recorded_span(ref, sut)
    start = start if start is not None else first
    end = end if end is not None else last
    edges = window_edges(start, end, window)
    if not edges:
        raise InputError(f"{start} - {end} holds no whole window of {window:g} s")
    options.setdefault("progress", False)
    pair = (ref, ref_xml, sut, sut_xml)

    if pool_inflation and options.get("inflation_floor") is not None:
        raise InputError("give pool_inflation or inflation_floor, not both")

    def fitted(k, **extra):
        w = fit_window(pair, *edges[k], seed + k, **options, **extra)
        if on_window is not None:
            on_window(k, len(edges), w)
        return w

    out = [fitted(k) for k in range(len(edges))]
    if pool_inflation:
        from .pooling import floor_windows
        out = floor_windows(out, lambda k, floor: fitted(k, inflation_floor=floor))
    return out
