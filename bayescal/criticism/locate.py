"""Where the fitted model and the recordings disagree: the standardised misfit
per band and SUT channel with its p-value, the recorded/predicted ratio per
band, coherences and the per-segment timing trend (see :mod:`.diagnose`).
"""
from __future__ import annotations


import numpy as np

from ..core.checks import ALPHA, band_p_values, mismatch_flags  # noqa: F401 (ALPHA re-exported)

# --- locate -----------------------------------------------------------------


def band_ratio(model, theta):
    """(B, n_u) complex ratio of what each SUT channel recorded (deconvolved
    by the model's response) over what the model predicts from the
    reference, per band: ``(S_ur t_i) / (t_i S_rr t_i)``; 1 where it fits."""
    vecs, _ = model.unpack(theta)
    t = (vecs @ model.ref_pinv)[0]                                   # (nu, nr)
    r = model.residual(np.atleast_2d(theta))[0]                      # (B, nu, nr)
    srr = model.reference_band_sums
    sur = r + np.einsum("ij,bjk->bik", t, srr)
    num = np.einsum("bij,ij->bi", sur, t)
    den = np.einsum("ij,bjk,ik->bi", t, srr, t).real
    return num / den


def band_coherence(spectra):
    """(B, n_u) mean multiple coherence of each SUT channel in each band."""
    mc = spectra.multiple_coherence()                                 # (nu, F)
    return np.stack([mc[:, spectra.band_of == b].mean(axis=1) for b in range(spectra.n_bands)])


def ratio_weights(spectra):
    """(B, n_u) inverse variance of ``log q`` per band (bins x segments x
    signal-to-noise)."""
    coh = np.clip(band_coherence(spectra), 1e-6, 1 - 1e-9)
    n = spectra.bins_per_band[:, None] * spectra.n_segments
    return n * coh / (1 - coh)


def locate(model, theta):
    """Where the model at ``theta`` (with its noise model set) misfits.

    Returns dict with ``misfit`` (B, n_u), ``p_value`` (B, n_u), ``flag``
    (B, n_u) booleans and ``mismatch``: contiguous runs of flagged bands as
    ``{"band_hz", "channels", "p_value", "misfit_max", "amplitude_off",
    "phase_off_rad"}``, the last two the size of what the model leaves
    there: the largest ``| |q| - 1 |`` and ``|arg q|`` of the ratio
    recorded/predicted (:func:`band_ratio`) over the run's flagged cells."""
    sp = model.spectra
    v = model.standardized_band_residuals(theta)
    p = band_p_values(v, sp.n_r)
    flag = mismatch_flags(p)
    ids = [b.channel_id for b in model.blocks]
    runs = []
    q = band_ratio(model, theta) if flag.any() else None
    for b, e in true_runs(flag.any(axis=1)):
        cells = q[b:e][flag[b:e]]
        runs.append({"band_hz": [float(sp.band_edges[b]), float(sp.band_edges[e])],
                     "channels": [ids[i] for i in np.flatnonzero(flag[b:e].any(axis=0))],
                     "p_value": float(p[b:e].min()),
                     "misfit_max": float(v[b:e].max()),
                     "amplitude_off": float(np.max(np.abs(np.abs(cells) - 1))),
                     "phase_off_rad": float(np.max(np.abs(np.angle(cells))))})
    return {"misfit": v, "p_value": p, "flag": flag, "mismatch": runs}


def segment_timing(model, theta):
    """Per-segment timing residual (s, relative to the record's mean) and a
    weight, from the phase of each segment's band cross-spectra against the
    model's prediction: the raw material of the clock-drift signature."""
    sp = model.spectra
    nu = sp.n_u
    vecs, _ = model.unpack(theta)
    t = (vecs @ model.ref_pinv)[0]
    seg = sp.per_segment
    c = np.einsum("kbij,ij->kb", seg[:, :, :nu, nu:], t)               # (K, B)
    mean_phase = np.angle(c.sum(axis=0))
    phase = np.angle(c * np.exp(-1j * mean_phase)[None])
    w = ratio_weights(sp).sum(axis=1)
    # effective frequency of each band's phase: bins weighted by the
    # predicted cross-power (the geometric band centre would bias tau)
    power = np.abs(np.einsum("fij,ij->f", sp.total[:, :nu, nu:], t))
    f = np.bincount(sp.band_of, power * sp.freqs, sp.n_bands) / np.bincount(
        sp.band_of, power, sp.n_bands)
    tau = -np.sum(w * f * phase, axis=1) / (2 * np.pi * np.sum(w * f * f))
    times = (sp.segment_starts + sp.nperseg / 2.0) / sp.fs
    return times, tau, np.ones_like(tau)


def block_timing(model, theta, lag_step=None):
    """Per-time-block timing (s) and the blocks' mean times (s): the lag that
    best aligns each block's SUT-reference cross-spectrum (weighted by the
    model's prediction) within the timing candidates' range (a generalised
    cross-correlation: the bins are consecutive Fourier bins, so one
    zero-padded inverse FFT per block gives every lag at once). Unlike
    :func:`segment_timing`'s phase slope it does not wrap when the clock
    runs off by more than a quarter period of the band's top, as a drift of
    tens of ppm does over hours. ``lag_step``: the lag resolution before the
    peak is refined (default a fortieth of the band's top period). Returns
    (times, tau, weights), or None without time blocks."""
    sp = model.spectra
    if sp.block_totals is None or sp.block_totals.shape[0] < 2 or sp.freqs.size < 2:
        return None
    nu = sp.n_u
    vecs, _ = model.unpack(theta)
    t = (vecs @ model.ref_pinv)[0]
    fmin, fmax = float(sp.band_edges[0]), float(sp.band_edges[-1])
    span = min(5.0, 0.5 / fmin)
    df = float(sp.freqs[1] - sp.freqs[0])
    step = lag_step or 0.025 / fmax
    n = int(2 ** np.ceil(np.log2(max(1.0 / (df * step), 2.0 * sp.freqs.size))))
    lags = np.fft.fftfreq(n, df)                        # the lag of each output sample (s)
    inside = np.flatnonzero(np.abs(lags) <= span)
    inside = inside[np.argsort(lags[inside])]
    g_count = sp.block_totals.shape[0]
    best = np.empty(g_count)
    for g in range(g_count):
        c = np.einsum("fij,ij->f", sp.block_totals[g, :, :nu, nu:].astype(complex), t)
        c = np.where(np.isfinite(c), c, 0.0)
        # sum_k c_k exp(+2 pi i k df L) at L = j / (n df): n times numpy's inverse FFT
        score = np.abs(np.fft.ifft(c, n))[inside]
        k = int(np.argmax(score))
        x = lags[inside]
        if 0 < k < x.size - 1:          # refine between grid points (a parabola)
            a, b, d = score[k - 1], score[k], score[k + 1]
            den = a - 2 * b + d
            best[g] = x[k] + (0.5 * (a - d) / den * (x[k + 1] - x[k]) if den < 0 else 0.0)
        else:
            best[g] = x[k]
    return sp.block_times(), best, np.ones_like(best)


# --- candidates -------------------------------------------------------------

def true_runs(mask):
    """(first, end) band indices of each run of True in ``mask``."""
    edges = np.flatnonzero(np.diff(np.r_[0, mask.astype(int), 0]))
    return list(zip(edges[::2], edges[1::2]))


def overdispersion(model, theta):
    """The median standardised misfit of ``model`` over bands and channels,
    at least 1: how much more than its noise the model still misses by
    everywhere (1 for a model that fits)."""
    return max(1.0, float(np.median(locate(model, theta)["misfit"])))
