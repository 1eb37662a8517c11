"""The variance of a random run's band residual, computed from the recorded
input.

A band residual of :class:`bayescal.coil.element.RunModel` sums, over the
band's bins and the K segments, the output's noise times the input:
``R_b = sum_k sum_{f in b} Z_n,k(f) conj(Z_a,k(f))`` (``Z`` the windowed,
detrended segment's DFT, ``a`` the input as ground velocity). That is a
linear functional of the noise's time series, ``R_b = sum_t n(t) g_b(t)``,
whose kernel ``g_b`` is known: the segments' windows times the inverse DFT
of the input's band-limited spectrum, placed at each segment's start. For
stationary noise of power spectral density ``S``,

    Var R_b = (1 / M) sum_m |G_b(m)|^2 S(nu_m)        (G_b the M-point DFT of g_b),

which holds the correlations of neighbouring bins (the window's leakage)
and of overlapping segments for this record's input. The likelihood keeps
the noise's level per band from the residual's power and takes from this
formula only the ratio ``c_b`` of the variance to the independent-bin value
``sum_{f in b} S_AA(f) E|Z_n(f)|^2``, both computed with a smooth shape
``S_0`` of the noise spectrum (a quadratic in log-log fitted to the
residual's periodogram, times the deconvolution's band taper squared). A
level error of ``S_0`` cancels in the ratio; its shape enters only through
the leakage of a few bins.

Measured from the scatter of a few segments' residuals (12 for an hour at
5 Hz) the ratio is noisy from run to run, and the intervals' widths with it;
``c_b`` from the input depends on the noise only through its smooth shape,
and matches the variance of 400 simulated noise realisations within their
5 % error per band (``tests/test_cal.py``, docs/validation/coil.md).
"""
from __future__ import annotations

import numpy as np
from ..core.spectra import band_taper, deconvolve_runs, hann, remove_line
from .runs import EDGE_PERIODS

#: Sub-bins per segment bin on which the kernels are summed (the shape
#: ``S_0`` is smooth at that scale).
SUB_BINS = 8
#: Segment bins either side of a bin that its window's leakage reaches.
LEAKAGE_BINS = 4
#: Complex values held at once while the kernels are built (memory bound).
CHUNK_VALUES = 1 << 23


class BandVariance:
    """``c_b`` of one run (module docstring): the kernels ``|G_b|^2``
    summed on sub-bins of the segment grid, and the window's leakage kernel.

    Parameters
    ----------
    run : :class:`bayescal.coil.runs.CalRun`, its ``input`` in counts.
    coil_constant : m/s^2 of equivalent ground acceleration per input count.
    spectra : the run's :class:`bayescal.core.spectra.CrossSpectra`
        (:func:`bayescal.coil.element.run_spectra`): segments and bands.
    band : (fmin, fmax) Hz, the band the spectra were computed for.
    """

    def __init__(self, run, coil_constant, spectra, band):
        fs, n = spectra.fs, spectra.nperseg
        self.band = (float(band[0]), float(band[1]))
        self.freqs = spectra.freqs
        self.band_of = spectra.band_of
        margin = int(round(EDGE_PERIODS * fs / self.band[0]))
        a = deconvolve_runs(run.input[None, :], fs,
                            lambda f: (2j * np.pi * np.asarray(f) / coil_constant)[None, :],
                            self.band, margin)[0]
        keep = np.flatnonzero(np.isin(np.fft.rfftfreq(n, 1.0 / fs), spectra.freqs))
        win = hann(n)
        z = np.array([np.fft.rfft(remove_line(a[s:s + n].copy()) * win)[keep]
                      for s in spectra.segment_starts])                      # (K, F)
        ratio = SUB_BINS * int(np.ceil(2.0 * a.size / (SUB_BINS * n)))
        self.m = ratio * n                            # DFT length, >= twice the record
        group = ratio // SUB_BINS
        self.g2 = np.vstack([self._kernels(z, keep, win, spectra, b, group)
                             for b in self._band_chunks(spectra.n_bands)])
        self.nu = np.abs(np.fft.fftfreq(SUB_BINS * n, 1.0 / fs)[:, None]
                         + np.arange(group)[None, :] * fs / self.m).mean(axis=1)
        d = np.arange(-LEAKAGE_BINS * SUB_BINS, LEAKAGE_BINS * SUB_BINS + 1)
        w2 = np.abs(np.fft.fft(win, self.m)) ** 2
        self.leak = np.array([w2[(dd * group + np.arange(group)) % self.m].sum() for dd in d])
        self.leak_idx = (keep[:, None] * SUB_BINS + d[None, :]) % (SUB_BINS * n)
        self.taper2 = band_taper(self.nu, self.band) ** 2

    def _band_chunks(self, n_bands):
        size = max(1, CHUNK_VALUES // (2 * self.m))
        return [np.arange(i, min(i + size, n_bands)) for i in range(0, n_bands, size)]

    def _kernels(self, z, keep, win, spectra, bands, group):
        """``|G_b|^2`` of ``bands``, summed over groups of ``group`` DFT
        points: (len(bands), SUB_BINS nperseg)."""
        n = spectra.nperseg
        g = np.zeros((bands.size, self.m), complex)
        inb = np.isin(spectra.band_of, bands)
        rows = np.searchsorted(bands, spectra.band_of[inb])
        for zk, s in zip(z, spectra.segment_starts):
            x = np.zeros((bands.size, n), complex)
            x[rows, keep[inb]] = zk[inb].conj()
            # the line's removal is a symmetric projection: its adjoint is itself
            g[:, s:s + n] += remove_line(np.fft.fft(x, axis=1) * win)
        g2 = np.abs(np.fft.ifft(g, axis=1) * self.m) ** 2
        return g2.reshape(bands.size, -1, group).sum(axis=2)

    def inflation(self, periodogram, input_power):
        """Per band, ``c_b = Var R_b`` over its independent-bin value, both
        under the smooth shape of ``periodogram``.

        Parameters
        ----------
        periodogram : (F,) the output residual's mean periodogram per bin
            (any positive scale).
        input_power : (F,) ``S_AA`` summed over the segments.

        Returns
        -------
        (B,) the ratios.
        """
        p = np.maximum(np.asarray(periodogram, float), 1e-300)
        coef = np.polyfit(np.log(self.freqs), np.log(p), 2)
        lo = self.band[0] / 4
        s0 = np.exp(np.polyval(coef, np.log(np.maximum(self.nu, lo)))) * self.taper2
        var = self.g2 @ s0
        per_bin = s0[self.leak_idx] @ self.leak
        return var / np.bincount(self.band_of, weights=input_power * per_bin,
                                 minlength=self.g2.shape[0])
