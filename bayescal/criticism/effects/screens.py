"""The response-side screens: how well the per-band ratio ``q[b, i]`` of
what SUT channel ``i`` recorded over what the fitted model predicts from
the reference (1 where the model fits;
:func:`bayescal.criticism.locate.band_ratio`) looks like a timing offset, a
missing pole or a gain error. A score ranks the candidates; the likelihood
comparison decides."""
from __future__ import annotations

import numpy as np


def _wls_slope(x, y, w):
    """Weighted least-squares slope through the origin and its R^2-like fit quality."""
    slope = np.sum(w * x * y) / np.sum(w * x * x)
    resid = np.sum(w * (y - slope * x) ** 2)
    total = np.sum(w * y * y) + 1e-30
    return slope, 1.0 - resid / total


def signatures(freqs_b, q, weight):
    """Score each response-side candidate from the per-band ratio ``q``
    (B, n_u) and per-band weights (B, n_u) (inverse variance of log q).

    Returns a dict name -> {"score": 0..1, "start": parameter guess, ...}.
    The score is how well the pattern matches (fit quality of the
    signature's shape); the likelihood comparison decides.
    """
    logq = np.log(np.where(np.abs(q) > 0, q, 1.0))
    amp, phase = logq.real, np.unwrap(logq.imag, axis=0)
    f = np.broadcast_to(freqs_b[:, None], q.shape)
    out = {}
    # timing: common phase slope on all channels
    slope, fit = _wls_slope(f.ravel(), phase.ravel(), weight.ravel())
    out["timing_offset"] = {"score": float(max(fit, 0)), "start": float(-slope / (2 * np.pi))}
    # extra pole: log-amplitude change with f^2 at low f x, phase ~ -f x
    mean_amp = np.average(amp, axis=1, weights=weight)
    mean_ph = np.average(phase, axis=1, weights=weight)
    wb = weight.sum(axis=1)
    trend = np.polyfit(np.log(freqs_b), mean_amp, 1, w=np.sqrt(wb))[0]
    pole_fit = float(max(_wls_slope(freqs_b, mean_ph, wb)[1], 0))
    out["extra_pole:sut"] = {"score": pole_fit * float(trend < 0), "amplitude_trend": float(trend)}
    out["extra_pole:ref"] = {"score": pole_fit * float(trend > 0), "amplitude_trend": float(trend)}
    # gain: per channel, flat amplitude offset with little phase
    for i in range(q.shape[1]):
        a = np.average(amp[:, i], weights=weight[:, i])
        spread = np.sqrt(np.average((amp[:, i] - a) ** 2, weights=weight[:, i]))
        out[f"gain_error:{i}"] = {"score": float(abs(a) / (abs(a) + spread + 1e-12)),
                                  "start": float(np.exp(a) - 1)}
    return out
