"""Degrees of freedom of Welch band averages: how many independent
samples a band-averaged cross-spectral matrix holds, with the overlap of
segments and the correlation of neighbouring bins counted (moment matching).
Every likelihood weight, self-noise interval and noise model that needs them
takes them from here."""
from __future__ import annotations

from functools import lru_cache

import numpy as np

from .welch import hann


def band_dof(spectra):
    """(B,) independent complex samples of each band of ``spectra`` (a
    :class:`~bayescal.core.spectra.welch.CrossSpectra`).

    For a band of ``m`` contiguous bins summed over segments, a statistic
    quadratic in white data has variance ``sum |rho|^2`` over all pairs of
    (segment, bin) where the independent-sample formula counts ``m K``; so
    ``nu = (m K)^2 / sum_{pairs} |rho|^2`` (the equivalent degrees of freedom
    of a Welch estimate, halved for complex samples). ``rho`` between bins
    ``j`` apart of one segment, and of every two segments that overlap (not
    only neighbours: above 50 % overlap segments further apart do too),
    follows from the window alone (periodic Hann, as
    :func:`bayescal.core.spectra.welch.cross_spectra` uses):
    :func:`effective_dof`. A model's fit does not enter: a band that misfits
    is not counted as having fewer samples.

    The value depends on the segment layout only (window length, segment
    starts, bins per band): it is computed once per layout (a fit and its
    criticism re-estimate noise models many times over the same spectra).
    """
    layout = (int(spectra.nperseg), np.asarray(spectra.segment_starts, np.int64).tobytes(),
              np.asarray(spectra.bins_per_band, np.int64).tobytes())
    return _layout_dof(*layout).copy()


@lru_cache(maxsize=8)
def _layout_dof(nperseg, starts, bins):
    """:func:`effective_dof` of a periodic Hann window of ``nperseg`` samples
    at the segment ``starts`` and ``bins`` per band (int64 bytes)."""
    return effective_dof(hann(nperseg), np.frombuffer(starts, np.int64),
                         np.frombuffer(bins, np.int64))


def _window_correlation(window, lags):
    """|rho(lag, db)|^2 for white noise between the DFTs of two windowed
    segments ``lag`` samples apart, ``db`` bins apart: (L, N) array."""
    w = np.asarray(window, float)
    N = w.size
    norm = np.sum(w ** 2)
    out = []
    for lag in lags:
        lag = abs(int(lag))
        prod = np.zeros(N)
        if lag < N:
            prod[:N - lag] = w[lag:] * w[:N - lag]
        out.append(np.abs(np.fft.fft(prod)) ** 2 / norm ** 2)
    return np.array(out)


def _overlap_lags(starts, n):
    """Distinct start differences ``|s_i - s_j| < n`` over all ordered pairs
    of the sorted ``starts`` (the pair with itself included) and how often
    each occurs: what the K x K difference matrix gives, from the diagonals
    that can overlap only (O(K) per diagonal instead of K^2 memory: a day
    at 100 Hz in 2048-sample segments has 8400 of them)."""
    diffs = [np.zeros(starts.size, int)]
    for j in range(1, starts.size):
        d = starts[j:] - starts[:-j]      # grows with j entry by entry (sorted)
        d = d[d < n]
        if d.size == 0:
            break
        diffs += [d, d]                   # (i, i + j) and (i + j, i)
    return np.unique(np.concatenate(diffs), return_counts=True)


def effective_dof(window, segment_starts, bins_per_band):
    """(B,) degrees of freedom of a band-averaged cross-spectral matrix.

    ``window`` (nperseg,) taper, ``segment_starts`` (K,) sample index of every
    segment used (gaps allowed), ``bins_per_band`` (B,). Moment matching for
    a spectrum flat over the band: ``nu = M^2 / sum_{m,m'} |rho_mm'|^2`` over
    the ``M = K * bins`` (segment, bin) pairs.
    """
    w = np.asarray(window, float)
    N = w.size
    s = np.sort(np.asarray(segment_starts, int))
    K = s.size
    lags, counts = _overlap_lags(s, N)
    rho2 = _window_correlation(w, lags)                    # (L, N)
    seg_term = counts @ rho2                               # (N,) sum over segment pairs
    out = []
    for B in np.atleast_1d(bins_per_band):
        B = int(B)
        dbins = np.arange(-(B - 1), B)
        tot = np.sum((B - np.abs(dbins)) * seg_term[dbins % N])
        out.append((K * B) ** 2 / tot)
    return np.array(out)
