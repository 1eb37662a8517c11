"""Least squares of a candidate effect from its grid's starting points
(:func:`.search.fit_candidate`): the best local maxima of the grid, each
refined by the fit's least squares (two passes, the noise model
re-estimated after each), the best end point under the current noise
model kept.

A start after the first is abandoned after its first pass when its misfit
under the current noise model (``-log L``, the whitened residual's squared
norm) exceeds :data:`ABANDON_RATIO` times the best end point's so far plus
:data:`ABANDON_SLACK`: the second pass refits the same model after a noise
re-estimate and changes that misfit by a modest factor. Measured on the
criticism's cases, every start fitted in full (the huddle pair in two
bands, the COWI pair as it is and with a hidden clock offset, a simulated
2-h 3+3 pair): the second pass lowered a start's misfit by at most a
factor 4.1, and the starts the rule abandons (the timing offset's other
phase-wrap modes) had a first-pass misfit at least 143 times the best
start's end point's. The first start's two passes run at once; a later
start that is not abandoned is refined as they are (its two passes split
at the noise re-estimate between them).
"""
from __future__ import annotations

import numpy as np

from ..core.model import forward_jacobian
from ..core.fit import least_squares_fit

#: A later start is abandoned after its first pass when its misfit exceeds
#: this many times the best end point's so far ...
ABANDON_RATIO = 20.0
#: ... plus this (a BIC threshold's worth of log-likelihood).
ABANDON_SLACK = 10.0


def grid_starts(trial, ll, n):
    """The ``n`` best local maxima of ``ll`` along the grid ``trial`` (a
    delay's likelihood is multimodal: one least-squares run from the grid's
    best point can end in a neighbouring mode), best first."""
    inner = np.r_[True, ll[1:] >= ll[:-1]] & np.r_[ll[:-1] >= ll[1:], True] & np.isfinite(ll)
    idx = np.flatnonzero(inner)
    idx = idx[np.argsort(ll[idx])[::-1]][:n]
    return [trial[i] for i in idx] or [trial[int(np.argmax(ll))]]


def misfit_under(model, theta, noise):
    """``-log L`` of ``model`` at ``theta`` under ``noise`` (the model's own
    noise model is left as it was)."""
    own = model.noise
    model.adopt_noise(noise)
    try:
        return -float(model.log_likelihood(theta)[0])
    finally:
        model.adopt_noise(own)


def best_start_fit(model, starts, noise):
    """The best least-squares fit of ``model`` from ``starts`` (best first),
    compared under ``noise`` (the current model's): ``(theta, cov,
    own_noise)`` with ``own_noise`` the fit's re-estimated noise model, or
    None when no start ends inside the prior's support with a finite
    covariance. Later starts are abandoned as the module says."""
    best = None
    for theta0 in starts:
        jac = forward_jacobian(model, matmul=True)
        try:
            if best is None:            # nothing to compare with: both passes at once
                theta, cov = least_squares_fit(model, theta0, jac=jac)
            else:
                theta, cov = least_squares_fit(model, theta0, iterations=1, jac=jac)
                if best[0] >= 0 and misfit_under(model, theta, noise) > \
                        ABANDON_RATIO * best[0] + ABANDON_SLACK:
                    continue
                theta, cov = least_squares_fit(model, theta, iterations=1, jac=jac)
        except Exception:   # noqa: BLE001 - a start that fails is not a fit
            continue
        if not np.isfinite(model.log_prior(theta))[0] or not np.all(np.isfinite(np.diag(cov))):
            continue
        cost = misfit_under(model, theta, noise)
        if best is None or cost < best[0]:
            best = (cost, theta, cov, model.noise)
    return None if best is None else best[1:]
