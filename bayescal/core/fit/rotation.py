"""One reference channel, two SUT horizontals: the common rotation of the
SUT's horizontals, assuming they are orthogonal (the method of the ASL
Sensor Test Suite's azimuth test, Ringler et al. 2013).

A single horizontal reference channel of azimuth phi records
``r = G . u(phi)``. If the SUT's horizontals point along ``alpha`` and
``alpha + s 90`` (``s`` = +1 or -1 from their nominal order) they are an
orthonormal basis of the horizontal plane, so

    r = cos(phi - alpha) y_1 + s sin(phi - alpha) y_2

whatever the polarisation of the ground motion: the SUT's two channels
rebuilt along the reference's axis must equal the reference. Each band's
residual power ``P_b(alpha) = w^T S_b w`` (``w = (-cos, -s sin, 1)``, ``S_b``
the response-corrected cross-spectra of y_1, y_2, r summed over the band's
bins and segments) is a quadratic form in a unit vector: isotropic SUT noise
adds a constant, not a bias. With the noise power of each band profiled out,

    log L(alpha) = -sum_b N_b log P_b(alpha)

where ``N_b`` is the band's number of independent complex bins: its bins
times its segments, divided by the measured inflation (the spread of
per-segment residual powers, lag-one covariance of overlapping segments
included, against the independent-bin value). The posterior of the single
angle (uniform prior on the circle) is evaluated on a grid and sampled
exactly by inverse CDF: no Markov chain is needed. Without the orthogonality
assumption one reference channel does not determine either SUT azimuth.
"""
from __future__ import annotations

import numpy as np

from ..model.inflation import floor_inflation, overlapping_segments
from ..orientation.geometry import azimuth_dip, unit_vector
from ...result import Convergence

#: Nominal axes closer than this to horizontal count as horizontal, and the
#: nominal angle between the two SUT horizontals must be 90 within it.
HORIZONTAL_TOLERANCE_DEG = 30.0
#: Samples drawn from the grid posterior.
N_SAMPLES = 20000
ASSUMPTION = ("one reference channel: the SUT's two horizontals are assumed orthogonal "
              "(ASL's azimuth method) and their common rotation is estimated; their "
              "orthogonality is not tested; their gains are held at the metadata values (one "
              "reference channel cannot tell the two horizontals' gains from their rotation, "
              "and a gain error common to both does not bias it)")


def orthogonal_pair(ref_vectors, sut_nominal_vectors):
    """``(i, j, s)`` when the reference is one horizontal channel and the SUT
    has two nominally orthogonal horizontals ``i`` and ``j`` (``j`` at
    ``i + s 90`` degrees), else None."""
    ref = np.atleast_2d(np.asarray(ref_vectors, float))
    if ref.shape[0] != 1:
        return None
    _, ref_dip = azimuth_dip(ref[0])
    if abs(ref_dip) > HORIZONTAL_TOLERANCE_DEG:
        return None
    az, dip = azimuth_dip(np.asarray(sut_nominal_vectors, float))
    horiz = [k for k in range(len(dip)) if abs(dip[k]) < HORIZONTAL_TOLERANCE_DEG]
    if len(horiz) != 2:
        return None
    i, j = horiz
    d = (az[j] - az[i] + 180.0) % 360.0 - 180.0
    if abs(abs(d) - 90.0) > HORIZONTAL_TOLERANCE_DEG:
        return None
    return i, j, int(np.sign(d))


def _weights(alpha_deg, phi_deg, s):
    a = np.radians(phi_deg - np.asarray(alpha_deg, float))
    return np.stack([-np.cos(a), -s * np.sin(a), np.ones_like(a)], axis=-1)   # (..., 3)


def _power(s3, w):
    """Residual power ``w^T S w`` for S (..., 3, 3) and weights (A, 3) ->
    (A, ...)."""
    return np.einsum("ai,...ij,aj->a...", w, s3.real, w)


def log_likelihood(band_sums, n_eff, alpha_deg, phi_deg, s):
    """(A,) log-likelihood on a grid of rotations (see the module docstring)."""
    p = _power(band_sums, _weights(alpha_deg, phi_deg, s))       # (A, B)
    return -(np.log(np.maximum(p, 1e-300)) * n_eff).sum(axis=1)


def _inflation(per_segment, segment_starts, nperseg, bins, w, floor=None):
    """Spread of per-segment band residual powers against the
    independent-bin value (1 for independent bins, about 2 for Hann), at
    least ``floor`` (None, or (1,): :func:`~bayescal.core.model.inflation.floor_inflation`)."""
    p = _power(per_segment, w[None])[0]                          # (K, B)
    mean = p.mean(axis=0)
    d = p - mean
    var = (d ** 2).mean(axis=0)
    adjacent = overlapping_segments(segment_starts, nperseg)
    cov1 = (d[adjacent] * d[adjacent + 1]).sum(axis=0) / max(p.shape[0], 1)
    ratio = (var + 2.0 * cov1) * bins / np.maximum(mean ** 2, 1e-300)
    infl = float(np.median(np.clip(ratio, 0.5, 20.0)))
    return infl if floor is None else float(floor_inflation(np.array([infl]), floor)[0])


def fit_rotation(spectra, ref_vector, pair, seed=0, meta=None, inflation_floor=None):
    """Posterior of the SUT horizontals' common azimuth from one reference
    channel (see the module docstring). ``pair`` is :func:`orthogonal_pair`'s
    answer; ``inflation_floor``: None, or (1,) a lower bound on the fit's
    one noise inflation (:mod:`bayescal.record.pooling`). Returns a
    :class:`bayescal.core.posterior.state.FitState` with both channels of
    kind "circle", their azimuths differing by exactly 90."""
    from ..posterior.state import FitState

    i, j, s = pair
    phi, _ = azimuth_dip(np.asarray(ref_vector, float).reshape(3))
    nu = spectra.n_u
    idx = [i, j, nu]
    sums = spectra.band_sums()[:, idx][:, :, idx]                         # (B, 3, 3)
    seg = spectra.per_segment[:, :, idx][:, :, :, idx]                    # (K, B, 3, 3)
    bins = spectra.bins_per_band.astype(float)
    coarse = np.arange(0.0, 360.0, 0.25)
    best = coarse[np.argmax(log_likelihood(sums, bins * spectra.n_segments, coarse, phi, s))]
    infl = _inflation(seg, spectra.segment_starts, spectra.nperseg, bins,
                      _weights(best, phi, s), inflation_floor)
    n_eff = bins * spectra.n_segments / infl
    for half in (2.0, 20.0, 180.0):        # widen until the grid holds the posterior
        grid = np.linspace(best - half, best + half, 8001)
        lp = log_likelihood(sums, n_eff, grid, phi, s)
        best = grid[np.argmax(lp)]
        if half == 180.0 or min(lp[0], lp[-1]) < lp.max() - 40.0:
            break
    prob = np.exp(lp - lp.max())
    prob /= prob.sum()
    rng = np.random.default_rng(seed)
    step = grid[1] - grid[0]
    alpha = rng.choice(grid, size=N_SAMPLES, p=prob) + rng.uniform(-step / 2, step / 2,
                                                                    N_SAMPLES)
    flat = np.zeros_like(alpha)
    vectors = np.stack([unit_vector(alpha, flat), unit_vector(alpha + s * 90.0, flat)], axis=1)
    ids = [str(spectra.sut_ids[k]) if spectra.sut_ids else str(k) for k in (i, j)]
    others = {str(cid): "a one-channel horizontal reference cannot see it"
              for k, cid in enumerate(spectra.sut_ids or range(nu)) if k not in (i, j)}
    meta = dict(meta or {})
    misfit = _power(sums, _weights([best], phi, s))[0] / (bins * spectra.n_segments)
    meta.update({"free_response": "none", "assumption": ASSUMPTION, "method":
                 "exact grid posterior of one rotation angle (no MCMC)",
                 "band_hz": [float(spectra.band_edges[0]), float(spectra.band_edges[-1])],
                 "band_edges_hz": spectra.band_edges, "n_segments": spectra.n_segments,
                 "n_segments_possible": spectra.n_segments_possible,
                 "segment_s": spectra.nperseg / spectra.fs, "noise_inflation": [infl],
                 "sampler": {"library": None, "draws": N_SAMPLES,
                             "approximation": "exact grid posterior of one rotation angle "
                                              "(no MCMC)"}})
    sub = spectra.select([i, j])
    diagnostics = {"freqs": sub.freqs, "psd": sub.psd(), "band_edges": sub.band_edges,
                   "multiple_coherence": sub.multiple_coherence(),
                   "residual_power_per_bin": misfit, "noise_inflation": [infl],
                   "sut_ids": np.array(ids), "ref_ids": np.array(sub.ref_ids)}
    return FitState(channel_ids=ids, kinds=["circle", "circle"], vectors=vectors, response={},
                    samples=alpha[:, None], names=["rotation_deg"], log_prob=np.zeros(N_SAMPLES),
                    convergence=Convergence(tau=np.ones(1), ess=np.array([float(N_SAMPLES)]),
                                            rhat=np.ones(1), acceptance=1.0, n_steps=0,
                                            n_walkers=0, burn=0, converged=True),
                    meta=meta, not_estimable=others, diagnostics=diagnostics)
