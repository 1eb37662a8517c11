"""Choosing the analysis band from the data: where the two sensors are
coherent.

:func:`choose_band` computes, over the widest band the record allows, the
squared multiple coherence of every SUT channel with all reference channels
(the fraction of its power the reference explains), smooths it over a tenth
of a decade, and returns the widest contiguous frequency range (in log
frequency) where every SUT channel the reference can see is above
``threshold``. Channels the reference cannot see (a SUT vertical beside a
horizontal-only reference: nominal axis outside the span of the reference
axes) and channels whose coherence never reaches the threshold are left out
of the criterion; the fit reports the former as not estimable.
"""
from __future__ import annotations

import bisect
from dataclasses import dataclass

import numpy as np

from ..errors import InputError
from ..core.spectra import welch_multiple_coherence

#: Default coherence a band must have on every visible SUT channel.
DEFAULT_THRESHOLD = 0.9
#: Below this band-mean multiple coherence a SUT channel shares too little
#: with the reference to be estimated (less than a tenth of its power): a fit
#: would be set by its own noise (azimuths of a dead sensor, at
#: coherence 0.002, scattered from 34 to 381 degrees between windows, each
#: with a +-13 degree interval).
MIN_COHERENCE = 0.1
#: The band must span at least this ratio fmax / fmin.
MIN_RATIO = 1.5
#: Upper limit as a fraction of Nyquist (stay clear of anti-alias filters).
NYQUIST_FRACTION = 0.8


@dataclass
class BandChoice:
    """The chosen band and the evidence for it."""

    fmin: float
    fmax: float
    threshold: float
    channels: list          # SUT channels used in the criterion
    freqs: np.ndarray
    coherence: np.ndarray   # (n_u, F) smoothed multiple coherence

    @property
    def band(self):
        return (self.fmin, self.fmax)

    def describe(self):
        """One line saying which band was chosen and why."""
        return (f"band {self.fmin:.4g} - {self.fmax:.4g} Hz chosen from the data: multiple "
                f"coherence above {self.threshold:g} on {', '.join(self.channels)}")


def _smooth(freqs, values, decades=0.1):
    """Running median over ``decades`` of log frequency.

    The windows only move up with frequency, so each row keeps its window
    as a sorted list (one insertion or removal per sample entering or
    leaving); the median is the middle element or the mean of the two middle
    ones, exactly ``np.median`` of the window (NaN when the window holds a
    NaN), in a fraction of the time of one ``np.median`` per frequency."""
    logf = np.log10(freqs)
    values = np.asarray(values, float)
    out = np.empty_like(values)
    lo = np.searchsorted(logf, logf - decades / 2)
    hi = np.searchsorted(logf, logf + decades / 2, side="right")
    rows = values.reshape(-1, values.shape[-1])
    flat = out.reshape(rows.shape)
    for r, row in enumerate(rows):
        vals = row.tolist()
        window, nans, a, b = [], 0, 0, 0
        res = flat[r]
        for k in range(freqs.size):
            while b < hi[k]:
                v = vals[b]
                if v != v:
                    nans += 1
                else:
                    bisect.insort(window, v)
                b += 1
            while a < lo[k]:
                v = vals[a]
                if v != v:
                    nans -= 1
                else:
                    del window[bisect.bisect_left(window, v)]
                a += 1
            m = len(window)
            if nans or not m:
                res[k] = np.nan
            else:
                res[k] = window[m // 2] if m % 2 else (window[m // 2 - 1] + window[m // 2]) / 2
    return out


def _widest_run(mask, freqs):
    best, start = None, None
    for k, ok in enumerate(np.r_[mask, False]):
        if ok and start is None:
            start = k
        elif not ok and start is not None:
            width = np.log(freqs[k - 1] / freqs[start])
            if best is None or width > best[0]:
                best = (width, start, k - 1)
            start = None
    return best


def _inside_span(sut, ref):
    """Indices of SUT channels whose nominal axis the reference can see."""
    from ..core.fit import SPAN_TOLERANCE_DEG, span_basis

    basis, _ = span_basis(np.asarray(ref.vectors, float))
    if basis.shape[0] == 3:
        return list(range(len(sut.ids)))
    inside = np.linalg.norm(np.asarray(sut.vectors, float) @ basis.T, axis=1)
    return [i for i in range(len(sut.ids)) if inside[i] >= np.cos(np.radians(SPAN_TOLERANCE_DEG))]


def choose_band(sut, ref, fs, threshold=DEFAULT_THRESHOLD, source=""):
    """Choose ``(fmin, fmax)`` from the coherence of aligned sides.

    Parameters
    ----------
    sut, ref : :class:`bayescal.io.Side` on the same grid.
    fs : sampling rate (Hz).
    threshold : multiple coherence required on every visible SUT channel.

    Returns a :class:`BandChoice`; raises :class:`bayescal.errors.InputError` when
    no band of useful width is coherent.
    """
    n = sut.data.shape[1]
    nperseg = int(2 ** np.floor(np.log2(max(n / 8, 16))))
    fmin = 10.0 * fs / nperseg
    fmax = NYQUIST_FRACTION * fs / 2
    if fmin >= fmax:
        raise InputError(f"{source}too little data to choose a band: {n / fs:.0f} s")
    # coherence is unchanged by each channel's own (invertible) response: no
    # deconvolution, so no run-edge margins either (core.spectra.coherence computes
    # only the coherence, not the fit's per-band and per-segment matrices)
    freqs, raw = welch_multiple_coherence(sut.data, ref.data, fs, (fmin, fmax), nperseg)
    coh = _smooth(freqs, np.clip(raw, 0, 1))
    visible = [i for i in _inside_span(sut, ref) if np.nanmax(coh[i]) >= threshold]
    if not visible:
        best = ", ".join(f"{sut.ids[i]} {np.nanmax(coh[i]):.3f}" for i in _inside_span(sut, ref))
        raise InputError(f"{source}no frequency band where the sensors are coherent: best "
                         f"multiple coherence per channel {best}, needed {threshold}")
    run = _widest_run(np.all(coh[visible] >= threshold, axis=0), freqs)
    if run is None or freqs[run[2]] / freqs[run[1]] < MIN_RATIO:
        raise InputError(f"{source}no frequency band of useful width where all SUT channels "
                         f"are coherent with the reference above {threshold}; give --band")
    return BandChoice(fmin=float(freqs[run[1]]), fmax=float(freqs[run[2]]),
                      threshold=threshold, channels=[sut.ids[i] for i in visible],
                      freqs=freqs, coherence=coh)


def coherence_gate(spectra, sut, ref, source="", minimum=MIN_COHERENCE):
    """Band-mean multiple coherence of each SUT channel the reference can see,
    above its no-signal level (``n_r / K`` for K segments), against
    ``minimum``. Returns ``{channel id: coherence}`` of the channels
    below it (not estimable); raises :class:`InputError`, with the coherence
    of every channel, when none is above it."""
    raw = np.clip(spectra.multiple_coherence(), 0.0, 1.0).mean(axis=1)
    # without common signal the estimate is not 0 but about n_r / K (K Welch
    # segments; Beta(n_r, K - n_r) for independent records): measure the excess
    null = min(spectra.n_r / max(spectra.n_segments, 1), 0.99)
    coh = np.clip((raw - null) / (1.0 - null), 0.0, 1.0)
    visible = _inside_span(sut, ref)
    low = {sut.ids[i]: float(coh[i]) for i in visible if coh[i] < minimum}
    if visible and len(low) == len(visible):
        lo, hi = spectra.band_edges[0], spectra.band_edges[-1]
        per = ", ".join(f"{cid} {c:.3f}" for cid, c in low.items())
        raise InputError(f"{source}too little coherence with the reference in {lo:.4g}-{hi:.4g} "
                         f"Hz to estimate anything: mean multiple coherence above its no-signal "
                         f"level {null:.3f}: {per} (needed "
                         f"{minimum:g}); a sensor dead or disconnected, or a band without "
                         "common signal")
    return low
