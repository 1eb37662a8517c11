"""Welch multiple coherence of SUT channels with the reference, and nothing
else: what the band choice needs (:func:`bayescal.io.band.choose_band`).

The same segments, window, detrending and cross-spectral convention as
:func:`bayescal.core.spectra.welch.cross_spectra` without deconvolution (coherence
does not change under each channel's own invertible response), but it keeps
only the segment-summed matrix: no per-band, per-segment or per-block
matrices, no response evaluation. The linear trend is removed in closed form
(projection on a centred ramp) rather than by least squares; the coherence
agrees with ``cross_spectra(...).multiple_coherence()`` to rounding
(``tests/test_band_coherence.py``), at about a third of its cost.
"""
from __future__ import annotations

import numpy as np

from ...errors import SpectraError
from .welch import hann


def _detrended(seg):
    """``seg`` (..., m) minus its least-squares line, in closed form."""
    m = seg.shape[-1]
    t = np.arange(m, dtype=float) - (m - 1) / 2.0
    slope = (seg @ t) / (t @ t)
    return seg - seg.mean(axis=-1, keepdims=True) - slope[..., None] * t


def welch_multiple_coherence(sut, ref, fs, band, nperseg, overlap=0.5, chunk=64):
    """Frequencies (F,) in ``band`` and (n_u, F) squared multiple coherence of
    each SUT channel with all reference channels, from Welch segments of
    ``nperseg`` samples; a segment touching a NaN is dropped."""
    data = np.vstack([np.atleast_2d(np.asarray(sut, float)), np.atleast_2d(np.asarray(ref, float))])
    n_u = np.atleast_2d(sut).shape[0]
    n_samples = data.shape[1]
    step = max(1, int(round(nperseg * (1 - overlap))))
    all_f = np.fft.rfftfreq(nperseg, 1.0 / fs)
    keep = np.flatnonzero((all_f >= band[0]) & (all_f <= band[1]))
    lo, hi = keep[0], keep[-1] + 1
    win = hann(nperseg)
    starts = np.arange(0, n_samples - nperseg + 1, step)
    total = np.zeros((hi - lo, data.shape[0], data.shape[0]), dtype=complex)
    used = 0
    for c0 in range(0, starts.size, chunk):
        idx = starts[c0:c0 + chunk, None] + np.arange(nperseg)[None, :]
        seg = data[:, idx].transpose(1, 0, 2)
        seg = seg[np.all(np.isfinite(seg), axis=(1, 2))]
        if not seg.shape[0]:
            continue
        z = np.fft.rfft(_detrended(seg) * win, axis=-1)[:, :, lo:hi]
        total += np.einsum("kif,kjf->fij", z, z.conj())
        used += seg.shape[0]
    if not used:
        raise SpectraError("no segment without gaps: every window touches missing data")
    if used < 4:
        raise SpectraError(f"only {used} gap-free segments of {nperseg / fs:.0f} s:"
                           " too little data for the band")
    cuu = np.real(np.einsum("fii->fi", total[:, :n_u, :n_u]))
    cur = total[:, :n_u, n_u:]
    expl = np.real(np.einsum("fij,fjk,fik->fi", cur, np.linalg.inv(total[:, n_u:, n_u:]),
                             cur.conj()))
    return all_f[lo:hi], (expl / cuu).T
