"""Segments where one sensor records what the other does not: a transient.

The likelihoods take each band's noise as stationary: every Welch segment's
incoherent power (what one sensor records and the other does not) drawn from
one distribution. Real records break this: a gust, a door, a car near one
vault adds seconds of noise to one sensor only. A few such segments dominate
a short record's incoherent power; the errors-in-variables model then cannot
tell whose noise it is (the reference's, which leans the axes and lowers the
gains, or the SUT's) and the intervals widen to cover both, and a model that
takes the reference as quiet is biased by them.

The test, per segment ``s``: the reference's channels predicted from the
SUT's by the record's own regression (per band, ``B_b = S_ru S_uu^-1`` from
all segments), and the power of what is left, ``r_s,b,k``. Under stationary
Gaussian noise ``2 nu_b r_s,b,k / sigma_b,k`` is chi-square with ``2 nu_b``
degrees of freedom, ``nu_b`` the band's equivalent complex degrees of
freedom in one Hann segment (:func:`bayescal.core.spectra.dof.effective_dof`),
and ``sigma_b,k`` is estimated robustly, from the median over the
:data:`NEIGHBOURS` segments on either side (unaffected while fewer than half
of them hold a transient): a transient stands out from the minutes around
it, while noise that rises and falls over hours (the day's cultural noise,
the microseism's) is the record's own and is left to the likelihoods'
inflation. Where the model misses the signal (a timing offset, a response
a few per cent off), part of the signal leaks into the leftover and rises
with it; ``sigma`` then carries that leak, in proportion to how much
stronger the segment's signal is than its neighbours' (:func:`_expected`),
so that a segment is not left out for the model's own misfit, which the
model check and its criticism are there to find. The sum
over bands and reference channels is the segment's statistic; a segment
whose chi-square tail probability is below ``alpha / K`` (Bonferroni over
the ``K`` segments: one false drop in ``1 / alpha`` stationary records) and
whose incoherent power is at least :data:`MIN_RATIO` times its neighbours'
typical is dropped (with long segments the chi-square test alone would
notice a few tens of per cent).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.special import gammaincc, gammainccinv

from .dof import effective_dof
from .welch import hann

#: Family-wise rate of dropping a segment from a record whose noise is
#: stationary.
ALPHA = 1e-3

#: A dropped segment holds at least this many times its neighbours' typical
#: incoherent power.
MIN_RATIO = 2.0

#: Segments on either side whose median is a segment's typical incoherent
#: power (15 half-overlapping segments: about 8 segment lengths).
NEIGHBOURS = 15


@dataclass
class Transients:
    """The test's outcome: ``dropped`` (K,) segments to leave out, ``ratio``
    (K,) each segment's incoherent power over the record's typical (about 1
    where the noise is stationary), ``alpha`` the family-wise rate."""

    dropped: np.ndarray
    ratio: np.ndarray
    alpha: float

    @property
    def count(self):
        return int(self.dropped.sum())


def find(spectra, alpha=ALPHA):
    """:class:`Transients` of ``spectra`` (a
    :class:`bayescal.core.spectra.welch.CrossSpectra`; module docstring)."""
    nu = spectra.n_u
    per = spectra.per_segment                                         # (K, B, n, n)
    k = per.shape[0]
    total = per.sum(axis=0)
    dof = 2.0 * effective_dof(hann(spectra.nperseg), np.zeros(1, int),
                              np.asarray(spectra.bins_per_band, int))  # (B,) real
    # e = [-B_b, I] y: the reference's channels less their prediction from the SUT's
    coef = np.linalg.pinv(total[:, :nu, :nu], hermitian=True) @ total[:, :nu, nu:]  # (B, nu, nr)
    a = np.concatenate([-np.swapaxes(coef, 1, 2).conj(),
                        np.broadcast_to(np.eye(spectra.n_r), (per.shape[1], spectra.n_r,
                                                              spectra.n_r))], axis=2)
    resid = np.real(np.einsum("bki,sbij,bkj->sbk", a, per, a.conj()))  # (K, B, nr)
    # the part of each reference channel the SUT's explain: its signal
    c = np.concatenate([np.swapaxes(coef, 1, 2).conj(),
                        np.zeros((per.shape[1], spectra.n_r, spectra.n_r))], axis=2)
    signal = np.real(np.einsum("bki,sbij,bkj->sbk", c, per, c.conj()))  # (K, B, nr)
    median = 2.0 * gammainccinv(dof / 2.0, 0.5) / dof                 # chi2 median / dof
    sigma = _expected(resid, signal) / median[None, :, None]
    with np.errstate(divide="ignore", invalid="ignore"):
        z = np.where(sigma > 0, resid / sigma, 0.0) * dof[None, :, None]
    q = z.sum(axis=(1, 2))
    n = float(dof.sum() * spectra.n_r)
    dropped = (gammaincc(n / 2.0, q / 2.0) < alpha / k) & (q / n >= MIN_RATIO)   # chi2 tail
    return Transients(dropped=dropped, ratio=q / n, alpha=float(alpha))


def _expected(resid, signal):
    """Each segment's typical leftover power: the running median of its
    neighbours' plus, where the model misses the signal (a timing offset, a
    response a few per cent off), the share of the segment's own signal
    that leaks into the leftover, ``beta (P_s - median P)``. ``beta`` per
    band and channel is the median over the segments stronger than their
    neighbours of ``(r_s - median r) / (P_s - median P)``: the misfit's
    leak if there is one (a minority of transients does not move it), about
    zero under stationary noise (clipped there). A segment whose signal is
    strong is then not taken for a transient because the model misses that
    signal."""
    m_r = _running_median(resid, NEIGHBOURS)
    m_p = _running_median(signal, NEIGHBOURS)
    excess = signal - m_p
    with np.errstate(divide="ignore", invalid="ignore"):
        slope = np.where(excess > 0, (resid - m_r) / excess, np.nan)
    beta = np.zeros(resid.shape[1:])
    ok = np.isfinite(slope)
    for idx in np.ndindex(*resid.shape[1:]):
        col = slope[(slice(None),) + idx][ok[(slice(None),) + idx]]
        if col.size:
            beta[idx] = max(float(np.median(col)), 0.0)
    return m_r + beta[None] * np.maximum(excess, 0.0)


def _running_median(x, half):
    """Median over ``x[max(0, s - half) : s + half + 1]`` along the first
    axis, for every ``s`` (the window shifted inside the record at its
    ends, so that every segment's median has ``2 half + 1`` values when the
    record holds them)."""
    k = x.shape[0]
    width = min(k, 2 * half + 1)
    out = np.empty_like(x)
    for s in range(k):
        lo = min(max(0, s - half), k - width)
        out[s] = np.median(x[lo:lo + width], axis=0)
    return out


def summary(result, spectra, t0=None):
    """result.json's account of the segments a transient left out: how many,
    their times (seconds from the record's start, or UTC if ``t0`` is
    given) and how much above the record's typical incoherent power each
    was."""
    times = spectra.segment_times()[result.dropped]
    length = spectra.nperseg / spectra.fs
    starts = [float(t - length / 2) for t in times]
    out = {"dropped": result.count, "alpha": result.alpha,
           "ratio": [round(float(r), 1) for r in result.ratio[result.dropped]],
           "segment_s": length,
           "note": "segments in which one sensor records noise the other does not, beyond "
                   "the noise of the minutes around them (a chi-square test of each segment's "
                   f"incoherent power against the segments around it, family-wise rate {result.alpha:g}); left out of the fit"}
    if t0 is not None:
        out["starts"] = [str(t0 + s) for s in starts]
    else:
        out["starts_s"] = starts
    return out
