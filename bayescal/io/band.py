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

from dataclasses import dataclass

import numpy as np

from .read import InputError
from ..core.spectra import cross_spectra

#: Default coherence a band must have on every visible SUT channel.
DEFAULT_THRESHOLD = 0.9
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
    """Running median over ``decades`` of log frequency."""
    logf = np.log10(freqs)
    out = np.empty_like(values)
    lo = np.searchsorted(logf, logf - decades / 2)
    hi = np.searchsorted(logf, logf + decades / 2, side="right")
    for k in range(freqs.size):
        out[..., k] = np.median(values[..., lo[k]:hi[k]], axis=-1)
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
    from ..core.sampler import SPAN_TOLERANCE_DEG, _span_basis

    basis, _ = _span_basis(np.asarray(ref.vectors, float))
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

    Returns a :class:`BandChoice`; raises :class:`bayescal.io.InputError` when
    no band of useful width is coherent.
    """
    n = sut.data.shape[1]
    nperseg = int(2 ** np.floor(np.log2(max(n / 8, 16))))
    fmin = 10.0 * fs / nperseg
    fmax = NYQUIST_FRACTION * fs / 2
    if fmin >= fmax:
        raise InputError(f"{source}too little data to choose a band: {n / fs:.0f} s")
    # coherence is unchanged by each channel's own (invertible) response: no
    # deconvolution, so no run-edge margins either
    spectra = cross_spectra(sut.data, ref.data, fs, None, None,
                            (fmin, fmax), nperseg=nperseg, sut_ids=sut.ids, ref_ids=ref.ids)
    coh = _smooth(spectra.freqs, np.clip(spectra.multiple_coherence(), 0, 1))
    visible = [i for i in _inside_span(sut, ref) if np.nanmax(coh[i]) >= threshold]
    if not visible:
        raise InputError(f"{source}no frequency band where the sensors are coherent "
                         f"(best multiple coherence {np.nanmax(coh):.2f}, needed {threshold}); "
                         "give --band")
    run = _widest_run(np.all(coh[visible] >= threshold, axis=0), spectra.freqs)
    if run is None or spectra.freqs[run[2]] / spectra.freqs[run[1]] < MIN_RATIO:
        raise InputError(f"{source}no frequency band of useful width where all SUT channels "
                         f"are coherent with the reference above {threshold}; give --band")
    return BandChoice(fmin=float(spectra.freqs[run[1]]), fmax=float(spectra.freqs[run[2]]),
                      threshold=threshold, channels=[sut.ids[i] for i in visible],
                      freqs=spectra.freqs, coherence=coh)
