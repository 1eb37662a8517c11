"""Welch multiple coherence of SUT channels with the reference, and nothing
else: what the band choice needs (:func:`bayescal.io.band.choose_band`).

The same segments, window, detrending and cross-spectral convention as
:func:`bayescal.core.spectra.welch.cross_spectra` without deconvolution (coherence
does not change under each channel's own invertible response), but it keeps
only the segment-summed matrix: no per-band, per-segment or per-block
matrices, no response evaluation. The coherence agrees with
``cross_spectra(...).multiple_coherence()`` to rounding
(``tests/test_band_coherence.py``), at about a third of its cost.
"""
from __future__ import annotations

import numpy as np

from ...errors import SpectraError
from .segments import gap_free, hann, segment_spectra


def welch_multiple_coherence(sut, ref, fs, band, nperseg, overlap=0.5, chunk=None):
    """Frequencies (F,) in ``band`` and (n_u, F) squared multiple coherence of
    each SUT channel with all reference channels, from Welch segments of
    ``nperseg`` samples; a segment touching a NaN is dropped (``chunk``:
    segments transformed at once, None: :func:`.segments.segment_spectra`'s
    default)."""
    data = np.vstack([np.atleast_2d(np.asarray(sut, float)), np.atleast_2d(np.asarray(ref, float))])
    n_u = np.atleast_2d(sut).shape[0]
    step = max(1, int(round(nperseg * (1 - overlap))))
    all_f = np.fft.rfftfreq(nperseg, 1.0 / fs)
    bins = slice(np.searchsorted(all_f, band[0], "left"), np.searchsorted(all_f, band[1], "right"))
    starts = np.arange(0, data.shape[1] - nperseg + 1, step)
    starts = starts[gap_free(data, starts, nperseg)]
    if not starts.size:
        raise SpectraError("no segment without gaps: every window touches missing data")
    if starts.size < 4:
        raise SpectraError(f"only {starts.size} gap-free segments of {nperseg / fs:.0f} s:"
                           " too little data for the band")
    total = np.zeros((bins.stop - bins.start, data.shape[0], data.shape[0]), dtype=complex)
    for _, z in segment_spectra(data, starts, hann(nperseg), bins, chunk):
        total += np.einsum("kif,kjf->fij", z, z.conj())
    cuu = np.real(np.einsum("fii->fi", total[:, :n_u, :n_u]))
    cur = total[:, :n_u, n_u:]
    expl = np.real(np.einsum("fij,fjk,fik->fi", cur, np.linalg.inv(total[:, n_u:, n_u:]),
                             cur.conj()))
    return all_f[bins], (expl / cuu).T
