"""Per-band noise scales for a time-domain fit (:mod:`.timedomain`): the
whitened residual split into frequency bands, each band's noise variance
multiplied by an unknown scale with an inverse-gamma prior, integrated out
(:mod:`bayescal.core.misfit_scale`).

Why: the AR noise model is fitted to the whole record and weights every
frequency alike, but a step's information sits in a few per cent of the
band (period and damping within a decade of the pendulum's corner). There
the AR spectrum can be off by tens of per cent (on the simulated 120 s step
runs the innovations' power is 1.2-1.45 times its nominal value at 5-50 mHz,
0.1-0.4 below 5 mHz), and a Gaussian likelihood with the AR level treated as
known turns that into intervals about 1.2 times too narrow. With a scale per
band, each band's level is re-estimated from its own innovations, and its
uncertainty (few DFT bins at the lowest frequencies) is carried into the
intervals: the band's term becomes ``-(a + k_b) log(1 + q_b / a)``.

Measured (docs/cal.md, "Step coverage"): on 60 simulated step runs it did
not bring the standardised errors' sd from about 1.16 to 1, so it is an
option (``TimeModel.band_shape``), not the default.

The innovations ``e`` (n samples, unit variance where the AR model is right)
are transformed by the real FFT; with ``E_j`` its coefficients, the Gaussian
term ``-|e|^2 / 2`` equals ``-sum_j w_j |E_j|^2 / n`` (``w_j = 1`` inside,
``1/2`` at 0 Hz and Nyquist, Parseval), so each interior bin is one complex
degree of freedom, ``q_b = sum_{j in b} w_j |E_j|^2 / n`` and ``k_b =
sum_{j in b} w_j``.
"""
from __future__ import annotations

import numpy as np
from scipy.fft import rfft

from ..core.misfit_scale import band_loglik

#: Bands per decade of frequency.
BANDS_PER_DECADE = 10
#: Fewest DFT bins in a band (narrow low bands are merged upward).
MIN_BINS = 4


class FrequencyBands:
    """Band index of each real-FFT bin of an ``n``-sample series at ``fs``:
    log-spaced, ``BANDS_PER_DECADE`` per decade, each holding at least
    ``MIN_BINS`` bins (0 Hz joins the first band)."""

    def __init__(self, n, fs, per_decade=BANDS_PER_DECADE, min_bins=MIN_BINS):
        self.n = int(n)
        nf = self.n // 2 + 1
        f = np.arange(nf) * fs / self.n
        lf = np.log10(np.maximum(f, f[1] if nf > 1 else 1.0))
        raw = np.floor((lf - lf[0]) * per_decade).astype(int)
        index = np.zeros(nf, int)
        band, count, last = 0, 0, raw[0]
        for j in range(nf):
            if raw[j] != last and count >= min_bins:
                band, count = band + 1, 0
            last = raw[j]
            index[j] = band
            count += 1
        if count < min_bins and band > 0:          # a short last band joins the one below
            index[index == band] = band - 1
        self.index = index
        self.n_bands = int(index.max()) + 1
        w = np.ones(nf)
        w[0] = 0.5
        if self.n % 2 == 0:
            w[-1] = 0.5
        self.weight = w
        self.dof = np.bincount(index, weights=w, minlength=self.n_bands)
        self._starts = np.flatnonzero(np.diff(index, prepend=-1))
        self.edges_hz = [(float(f[index == b].min()), float(f[index == b].max()))
                         for b in range(self.n_bands)]

    def energy(self, e):
        """``q`` (W, B): each band's share of ``|e|^2 / 2`` for innovations
        ``e`` (W, n)."""
        p = np.abs(rfft(np.atleast_2d(e), axis=1)) ** 2 * (self.weight / self.n)
        return np.add.reduceat(p, self._starts, axis=1)

    def log_likelihood(self, e, shape):
        """Sum of the marginalised band terms (``shape`` inf: ``-|e|^2 / 2``)."""
        return band_loglik(self.energy(e), self.dof, shape)
