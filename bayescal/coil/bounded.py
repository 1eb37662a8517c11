"""The posterior shared by every coil model: a flat prior inside the
model's ``bounds()`` plus its ``log_likelihood``, vectorised over walkers."""
from __future__ import annotations

import numpy as np


class BoundedPosterior:
    """Mixin: subclasses define ``bounds() -> (lo, hi)`` and
    ``log_likelihood(theta (W, ndim)) -> (W,)``."""

    def log_prior(self, theta):
        """0 strictly inside the bounds, -inf outside, shape (W,)."""
        theta = np.atleast_2d(theta)
        lo, hi = self.bounds()
        return np.where(np.all((theta > lo) & (theta < hi), axis=1), 0.0, -np.inf)

    def log_prob(self, theta):
        """Vectorised log posterior: theta (W, ndim) -> (W,); the likelihood
        is evaluated only inside the bounds."""
        theta = np.atleast_2d(theta)
        lp = self.log_prior(theta)
        out = np.full(theta.shape[0], -np.inf)
        ok = np.isfinite(lp)
        if ok.any():
            out[ok] = lp[ok] + self.log_likelihood(theta[ok])
        return out
