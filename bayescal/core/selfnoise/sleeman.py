"""Self-noise of co-located sensors from their cross-spectral matrices
(Sleeman, Van Wettum and Trampert 2006), with a parametric-bootstrap interval.

Plain numpy, no file I/O. The files-to-estimates shell is
:mod:`bayescal.io.noise`; the method, its checks and its limits are in
docs/noise.md.

Model and convention
--------------------
Channel spectra ``Z_i = h_i G + N_i`` of n >= 3 co-located channels of one
component (responses removed), ground motion G common, self-noise N_i
independent. Cross-spectral matrix ``C = E[Z Z^H]``, ``C[i, j] = Z_i conj(Z_j)``
(the convention of :mod:`bayescal.core.spectra.welch`: scipy's ``csd(x, y)`` is ``C[j, i]``).
Then ``C[i, j] = h_i conj(h_j) S_G`` off the diagonal and

    N_ii = C[i, i] - C[i, j] C[k, i] / C[k, j]          (j, k distinct from i)

exactly, for any complex relative responses h (so the estimate is immune to
errors of the *relative* response; an error of sensor i's own gain scales its
own estimate). The ratio is real in expectation; the estimator takes its real
part (its imaginary part and the difference between real part and modulus are
second order in N/S). To first order in the noise, the noise-times-signal
terms of ``C[i, i]`` and of the ratio cancel, so the estimate's relative error
is about ``1/sqrt(dof)`` even 60 dB below the ambient signal.

With n > 3 sensors each sensor's estimate is the median over the
``(n-1)(n-2)/2`` pairs (j, k) of the others: the median keeps one badly
placed or mis-described sensor from spoiling everyone else's estimate (a joint
one-factor fit is more efficient only when every sensor obeys the model);
the spread over pairs is returned as a diagnostic of model error.

Interval
--------
A band-averaged matrix ``C_hat = (1/M) sum_m z_m z_m^H`` over M (segment,
bin) pairs of Welch spectra is, for Gaussian data with a spectrum smooth over
the band, close to a complex Wishart ``CW(nu, C / nu)`` whose degrees of
freedom ``nu`` follow from the window's correlations between overlapping
segments and neighbouring bins (:func:`bayescal.core.spectra.dof.effective_dof`, moment matching).
:func:`wishart_interval` draws ``C* ~ CW(nu, C_hat / nu)`` (complex Bartlett
decomposition), recomputes the estimator and forms a *basic* bootstrap
interval on the linear power scale, ``[N - q_hi, N - q_lo]`` of
``d* = N* - N`` (which removes the estimator's bias to first order; see
:func:`_basic_interval` for why linear). :func:`block_bootstrap_interval`
resamples blocks of segments instead (no Gaussian or stationarity
assumption, coarser with few segments; it under-covers, docs/noise.md).
"""
from __future__ import annotations

from dataclasses import dataclass, field
from itertools import combinations

import numpy as np

__all__ = ["sleeman", "triplet_estimates", "self_noise", "self_noise_band_sums",
           "acceleration_band_matrices", "sample_complex_wishart",
           "wishart_interval", "block_bootstrap_interval", "SelfNoise", "estimate_self_noise",
           "period_band_weights", "below_resolution", "db"]


def db(x):
    """10 log10 of a positive power; NaN where ``x <= 0``."""
    x = np.asarray(x, float)
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.where(x > 0, 10 * np.log10(np.where(x > 0, x, 1.0)), np.nan)


# --- estimator ------------------------------------------------------------------
def sleeman(C, i, j, k):
    """Self-noise power of channel ``i`` from channels ``j``, ``k``:
    ``Re(C_ii - C_ij C_ki / C_kj)`` over the leading axes of ``C`` (..., n, n)."""
    C = np.asarray(C)
    return np.real(C[..., i, i] - C[..., i, j] * C[..., k, i] / C[..., k, j])


def triplet_estimates(C):
    """(..., n, P) the estimate of every channel from every pair of the others,
    ``P = (n-1)(n-2)/2``; pairs in ``combinations`` order of the others."""
    C = np.asarray(C)
    n = C.shape[-1]
    if n < 3:
        raise ValueError("self-noise needs at least three co-located channels")
    out = []
    for i in range(n):
        others = [m for m in range(n) if m != i]
        out.append(np.stack([sleeman(C, i, j, k) for j, k in combinations(others, 2)], -1))
    return np.stack(out, axis=-2)


def self_noise(C):
    """(..., n) self-noise power of each channel: Sleeman's estimate for three
    channels, the median over pairs of the others for more."""
    return np.median(triplet_estimates(C), axis=-1)


def self_noise_band_sums(band_sums, sensor=0, clip=False):
    """Self-noise of one sensor summed over each band, for a pair likelihood
    that takes the reference's noise as known (``ref_noise="fixed"``).

    ``band_sums`` (..., B, n, n): per band, the sum over the band's bins and
    the used segments of ``Z Z^H`` for one component (say Z) of ``n >= 3``
    co-located sensors, responses removed, in the pair fit's ground units
    (e.g. :meth:`bayescal.core.spectra.welch.CrossSpectra.band_sums` of
    ``cross_spectra`` run on the three sensors' channels of that component,
    with the pair fit's band, segment length and bands). ``sensor``: the
    index of the reference among the n channels. Returns (..., B): the
    reference channel's self-noise power summed over the same bins and
    segments, i.e. the ``d_b`` of the errors-in-variables residual
    ``S_ur - T (S_rr - diag(d))``, for one reference channel; stack one call
    per reference component for ``(B, n_r)``.

    The estimator is homogeneous of degree one in the matrices (so band sums
    give band sums of noise) and exact whatever the sensors' relative complex
    responses, as long as those are constant across a band. Where the
    reference is much quieter than the others the estimate can be negative
    (its error is set by the others' noise); ``clip=True`` sets such bands
    to 0. If the three-sensor spectra used ``K3`` segments and the pair's
    ``K2``, multiply by ``K2 / K3``.
    """
    C = np.asarray(band_sums, complex)
    C = 0.5 * (C + np.conj(np.swapaxes(C, -1, -2)))
    if not 0 <= sensor < C.shape[-1]:
        raise ValueError(f"sensor index {sensor} outside 0..{C.shape[-1] - 1}")
    out = self_noise(C)[..., sensor]
    return np.maximum(out, 0.0) if clip else out


def acceleration_band_matrices(spectra):
    """(B, n, n) band-mean acceleration PSD matrices, (m/s^2)^2/Hz, and (B,)
    band frequencies (geometric mean of each band's bins), from a
    :class:`bayescal.core.spectra.welch.CrossSpectra` in ground velocity.

    The velocity band mean becomes acceleration by the factor
    ``1 / mean(1 / omega^2)`` over the band's bins: exact for noise flat in
    acceleration, within 0.1 dB otherwise at 16 bands per decade.
    """
    K = spectra.n_segments
    nb = spectra.bins_per_band
    w2 = (2 * np.pi * spectra.freqs) ** 2
    inv_w2 = np.bincount(spectra.band_of, weights=1.0 / w2, minlength=spectra.n_bands) / nb
    fc = np.exp(np.bincount(spectra.band_of, weights=np.log(spectra.freqs),
                            minlength=spectra.n_bands) / nb)
    C = spectra.band_sums() * (spectra.psd_scale / (K * nb * inv_w2))[:, None, None]
    return C, fc


# --- sampling distribution ------------------------------------------------------------
def sample_complex_wishart(rng, sigma, dof, size):
    """``size`` draws of ``W / dof`` with ``W ~ CW(dof, sigma)``: complex Wishart
    by the Bartlett decomposition (real ``dof >= n`` allowed).

    ``sigma`` (..., n, n) Hermitian positive definite, ``dof`` scalar or
    broadcastable to sigma's leading shape. Returns (size, ..., n, n).
    """
    sigma = np.asarray(sigma, complex)
    n = sigma.shape[-1]
    lead = sigma.shape[:-2]
    dof = np.broadcast_to(np.asarray(dof, float), lead)
    L = np.linalg.cholesky(sigma)
    A = np.zeros((size,) + lead + (n, n), complex)
    for i in range(n):
        A[..., i, i] = np.sqrt(rng.gamma(dof - i, 1.0, size=(size,) + lead))
        for j in range(i):
            A[..., i, j] = (rng.standard_normal((size,) + lead)
                            + 1j * rng.standard_normal((size,) + lead)) / np.sqrt(2)
    LA = L @ A
    return LA @ np.conj(np.swapaxes(LA, -1, -2)) / dof[..., None, None]


def _basic_interval(point, reps, level):
    """Basic bootstrap interval on the linear power scale,
    ``[N - q_hi(N* - N), N - q_lo(N* - N)]``, the lower bound clipped at 0
    (then only an upper bound is given). ``point`` (...), ``reps`` (R, ...).

    Linear, not log: where a sensor is much quieter than the others its
    estimate's error is set by *their* noise, additive and independent of its
    own level (relative errors of 100 % and more, negative estimates), and a
    log-scale pivot under-covers there (simulations: 0.74 at long periods);
    where the relative error is small the two scales agree.
    """
    a = (1 - level) / 2
    d = np.asarray(reps) - point
    qlo, qhi = np.quantile(d, [a, 1 - a], axis=0)
    return np.maximum(point - qhi, 0.0), np.maximum(point - qlo, 0.0)


def _mismatch_leakage(rng, size, n, signal, axis_mismatch):
    """(size, B, n, n) leakage of incoherent horizontal ground motion through
    sensitive axes that differ by ``axis_mismatch`` rad rms per sensor and
    horizontal direction (the same draw for every band), horizontal PSD
    ``signal`` (B,)."""
    eps = rng.standard_normal((size, 2, n)) * axis_mismatch
    E = np.einsum("rdi,rdj->rij", eps, eps)
    return np.asarray(signal)[None, :, None, None] * E[:, None]


def wishart_interval(C, dof, level=0.9, n_boot=1000, seed=0, axis_mismatch=0.0, chunk=250,
                     combine=None):
    """Parametric-bootstrap interval of :func:`self_noise`.

    ``C`` (B, n, n) band-averaged matrices, ``dof`` (B,). ``axis_mismatch``
    (rad rms, 0 = off) adds to every replicate the leakage of incoherent
    horizontal ground motion (PSD taken equal to the mean recorded vertical
    PSD) through sensitive axes that differ between sensors: the model error
    that dominates when the ambient signal is 50-60 dB above the self-noise
    and that three channels alone cannot identify. ``combine`` (G, B)
    weights: the interval of the weighted means of the bands' estimates (see
    :func:`_combine`). Returns ``(lo, hi, reps)``: (B, n) bounds (G, n with
    ``combine``) and the (R, B, n) (or R, G, n) replicates.
    """
    rng = np.random.default_rng(seed)
    C = np.asarray(C, complex)
    C = 0.5 * (C + np.conj(np.swapaxes(C, -1, -2)))
    n = C.shape[-1]
    point = self_noise(C)
    signal = np.real(np.einsum("bii->b", C)) / n
    reps = []
    for r0 in range(0, n_boot, chunk):
        m = min(chunk, n_boot - r0)
        draw = sample_complex_wishart(rng, C, dof, m)
        if axis_mismatch:
            draw = draw + _mismatch_leakage(rng, m, n, signal, axis_mismatch)
        reps.append(self_noise(draw))
    point, reps = _combine(combine, point, np.concatenate(reps))
    lo, hi = _basic_interval(point, reps, level)
    return lo, hi, reps


def _combine(combine, point, reps):
    """``point`` (B, n) and ``reps`` (R, B, n) averaged over groups of bands
    with the (G, B) weights ``combine`` (unchanged when None).

    The bands' *estimates* are averaged, each replicate's with the same
    weights, rather than the estimator applied to averaged matrices: the
    ambient signal can change by tens of dB across a period band, and small
    band-to-band differences of the sensors' relative responses then leak
    signal into an estimate from summed matrices, but not into one band's.
    """
    if combine is None:
        return point, reps
    W = np.asarray(combine, float)
    return np.einsum("gb,bn->gn", W, point), np.einsum("gb,rbn->rgn", W, reps)


def block_bootstrap_interval(per_segment, level=0.9, n_boot=1000, block=4, seed=0,
                             combine=None):
    """Moving-block bootstrap over time segments.

    ``per_segment`` (K, B, n, n) band sums per segment (the ``per_segment`` of
    :class:`bayescal.core.spectra.welch.CrossSpectra`); blocks of ``block`` consecutive
    segments are drawn with replacement. ``combine``: see
    :func:`wishart_interval`. Returns ``(lo, hi, reps)``.
    """
    rng = np.random.default_rng(seed)
    P = np.asarray(per_segment)
    K = P.shape[0]
    block = max(1, min(int(block), K))
    starts = np.arange(K - block + 1)
    n_blocks = int(np.ceil(K / block))
    point = self_noise(P.sum(axis=0))
    reps = np.empty((n_boot,) + point.shape)
    for r in range(n_boot):
        s = rng.choice(starts, n_blocks)
        idx = (s[:, None] + np.arange(block)[None, :]).ravel()[:K]
        reps[r] = self_noise(P[idx].sum(axis=0))
    point, reps = _combine(combine, point, reps)
    lo, hi = _basic_interval(point, reps, level)
    return lo, hi, reps


# --- one call -----------------------------------------------------------------------------
@dataclass
class SelfNoise:
    """Self-noise of n co-located channels in B frequency bands.

    ``psd``, ``lo``, ``hi`` (n, B) in the units of the matrices given (PSD
    units); ``psd`` is NaN where the estimate is not positive (then ``lo`` is
    0 and ``hi`` an upper bound). ``pair_range`` (n, B, 2): min and max over
    the pairs of other sensors (equal to ``psd`` for three sensors).
    ``signal`` (n, B): each channel's total PSD (ambient + self-noise).
    """

    freqs: np.ndarray
    psd: np.ndarray
    lo: np.ndarray
    hi: np.ndarray
    dof: np.ndarray
    level: float
    method: str
    signal: np.ndarray
    pair_range: np.ndarray
    ids: list = field(default_factory=list)

    @property
    def period_s(self):
        return 1.0 / self.freqs

    def psd_db(self):
        return db(self.psd)

    def ci_db(self):
        """(2, n, B) bounds in dB (-inf / +inf where unbounded)."""
        with np.errstate(divide="ignore"):
            return np.stack([10 * np.log10(self.lo), 10 * np.log10(self.hi)])


def estimate_self_noise(C, dof, freqs, *, level=0.9, n_boot=1000, seed=0, per_segment=None,
                        method="wishart", block=4, axis_mismatch=0.0, ids=(), combine=None):
    """Self-noise estimates with intervals from band-averaged matrices.

    ``C`` (B, n, n) band-averaged PSD matrices (already in the units wanted,
    e.g. (m/s^2)^2/Hz), ``dof`` (B,) from :func:`bayescal.core.spectra.dof.band_dof`, ``freqs``
    (B,) band centres. ``method``: "wishart" (default) or "block", which
    needs ``per_segment`` (K, B, n, n) summing, up to one positive factor per
    band, to ``C``. ``axis_mismatch``: see :func:`wishart_interval`.
    ``combine`` (G, B) weights (rows summing to 1, e.g. from
    :func:`period_band_weights`): estimates and intervals of the weighted
    means of the bands' estimates instead of each band's (:func:`_combine`;
    then ``freqs``, ``dof``, ``signal`` and ``pair_range`` of the result are
    the groups' weighted geometric mean frequency, the degrees of freedom of
    the weighted mean, and the weighted means).
    """
    C = np.asarray(C, complex)
    C = 0.5 * (C + np.conj(np.swapaxes(C, -1, -2)))
    W = None if combine is None else np.asarray(combine, float)
    pairs = triplet_estimates(C)
    point = np.median(pairs, axis=-1)                     # (B, n)
    signal = np.real(np.einsum("bii->bi", C))
    if W is not None:
        point = np.einsum("gb,bn->gn", W, point)
        pairs = np.einsum("gb,bnp->gnp", W, pairs)
        signal = np.einsum("gb,bn->gn", W, signal)
    if method == "wishart":
        lo, hi, _ = wishart_interval(C, dof, level, n_boot, seed, axis_mismatch, combine=W)
    elif method == "block":
        if per_segment is None:
            raise ValueError("method 'block' needs per_segment")
        P = np.asarray(per_segment)
        scale = np.real(np.einsum("bii->b", C)) / np.real(np.einsum("kbii->b", P))
        lo, hi, _ = block_bootstrap_interval(P * scale[None, :, None, None], level, n_boot,
                                             block, seed, combine=W)
    else:
        raise ValueError(f"unknown interval method {method!r}")
    freqs, dof = np.asarray(freqs, float), np.asarray(dof, float)
    if W is not None:
        freqs = np.exp(W @ np.log(freqs) / W.sum(axis=1))
        dof = W.sum(axis=1) ** 2 / ((W ** 2) @ (1.0 / dof))
    T = lambda a: np.ascontiguousarray(np.moveaxis(a, 0, 1))   # (B, n) -> (n, B)
    return SelfNoise(freqs=freqs, psd=T(np.where(point > 0, point, np.nan)),
                     lo=T(lo), hi=T(hi), dof=dof, level=level, method=method,
                     signal=T(signal),
                     pair_range=np.moveaxis(np.stack([pairs.min(-1), pairs.max(-1)], -1), 0, 1),
                     ids=list(ids))


def period_band_weights(freqs, edges_s, span_s=None):
    """Weights that average the bands at ``freqs`` (Hz) over period bands.

    ``edges_s``: increasing period edges (s), e.g. (0.1, 0.3, 1, 3, 10). Each
    band belongs to the period band holding its centre period; a period band
    holding no band is left out. Returns ``(W, ranges)``: (G, B) weights, each
    row an equal-weight mean over its member bands (so, on log-spaced bands,
    a mean over log frequency of the linear power), and the G (shortest,
    longest) period edges, clipped to ``span_s`` (shortest, longest period
    analysed) when given.
    """
    f = np.asarray(freqs, float)
    per = 1.0 / f
    edges = np.asarray(edges_s, float)
    rows, ranges = [], []
    for a, b in zip(edges[:-1], edges[1:]):
        inside = (per >= a) & (per < b)
        if not inside.any():
            continue
        rows.append(inside / inside.sum())
        lo, hi = (a, b) if span_s is None else (max(a, span_s[0]), min(b, span_s[1]))
        ranges.append((float(lo), float(hi)))
    return np.array(rows).reshape(len(rows), f.size), ranges


def below_resolution(lo):
    """True where an interval's lower bound is zero power: the data cannot
    tell the self-noise from none, and only the upper bound is a result."""
    return ~(np.asarray(lo, float) > 0)
