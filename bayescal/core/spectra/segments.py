"""Windowed segments of a multichannel record and their spectra, a chunk of
segments at a time.

One FFT per channel and segment: the segments are cut from a strided view of
the record (no copy of the record), one chunk of them copied out, detrended
and windowed in place and transformed; memory holds one chunk (about
:data:`CHUNK_BYTES` of samples and as much of spectra), whatever the
record's length. The linear trend is removed in closed form (mean, then
projection on a centred ramp): the least-squares line of
``scipy.signal.detrend(x, type="linear")``, to rounding.
"""
from __future__ import annotations

import numpy as np
from numpy.lib.stride_tricks import sliding_window_view

#: Bytes of segment samples in one chunk (its spectra take about as many).
CHUNK_BYTES = 4 * 2 ** 20


def hann(m, sym=False):
    """Periodic Hann window of ``m`` samples, the same numbers as
    ``scipy.signal.windows.hann(m, sym=False)`` (importing scipy.signal would
    cost a command about a second of start-up: it imports scipy.stats)."""
    assert not sym
    fac = np.linspace(-np.pi, np.pi, m + 1)
    w = np.zeros(m + 1)
    for k, a in enumerate((0.5, 0.5)):
        w += a * np.cos(k * fac)
    return w[:-1]


def remove_line(x):
    """Subtract from ``x`` (..., m), in place, its least-squares straight line
    along the last axis; returns ``x``.

    The sums are numpy's own loops (``einsum``, ``mean``), not BLAS: their
    order is fixed by the array's shape, whereas OpenBLAS splits a long dot
    product among its threads, whose number is a process-wide setting that
    another thread may change meanwhile."""
    m = x.shape[-1]
    t = np.arange(m, dtype=float) - (m - 1) / 2.0
    x -= x.mean(axis=-1, keepdims=True)
    x -= (np.einsum("...m,m->...", x, t) / np.einsum("m,m->", t, t))[..., None] * t
    return x


def gap_free(data, starts, nperseg):
    """(K,) bool: the segments of ``nperseg`` samples starting at ``starts``
    hold only finite samples of ``data`` (n, N) on every channel."""
    bad = np.r_[0, np.cumsum(~np.all(np.isfinite(data), axis=0))]
    return bad[starts + nperseg] == bad[starts]


def segment_spectra(data, starts, win, bins, chunk=None):
    """Spectra of the detrended, windowed segments of ``data`` (n, N).

    Parameters
    ----------
    data : (n, N) float array (read, not changed).
    starts : (K,) first sample of each segment.
    win : (m,) window; the segments are ``m`` samples long.
    bins : slice of the ``rfft`` bins kept.
    chunk : segments per chunk; None: as many as hold :data:`CHUNK_BYTES`.

    Yields
    ------
    (c0, z) : the position in ``starts`` of the chunk's first segment and
        its (k, n, F) complex spectra (numpy's forward ``rfft``).
    """
    n, m = data.shape[0], win.size
    if chunk is None:
        chunk = max(1, CHUNK_BYTES // (8 * n * m))
    view = sliding_window_view(data, m, axis=1).transpose(1, 0, 2)     # (N-m+1, n, m)
    for c0 in range(0, starts.size, chunk):
        seg = view[starts[c0:c0 + chunk]]                                # (k, n, m), a copy
        remove_line(seg)
        seg *= win
        yield c0, np.fft.rfft(seg, axis=-1)[:, :, bins]
