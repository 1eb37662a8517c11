"""The posterior shared by every coil model: a flat prior inside the
model's ``bounds()``, times, for a model of the pendulum pair, the stated
prior on period and damping carried to the sampling coordinates
``(c0_rel, c1_rel)`` with its Jacobian (:mod:`bayescal.core.response.pendulum`),
plus its ``log_likelihood``, vectorised over walkers; and what the prior
sets, from the posterior's samples reweighted to a rescaled prior."""
from __future__ import annotations

import numpy as np

from ..core.response import (log_prior as pendulum_log_prior,
                             prior_residual as pendulum_prior_residual, reweighted_sensitivity)
from ..core.priors import Priors


class BoundedPosterior:
    """Mixin: subclasses define ``bounds() -> (lo, hi)`` and
    ``log_likelihood(theta (W, ndim)) -> (W,)``; a model of the pendulum
    pair sets ``pendulum_index`` (the index of ``c0_rel``, ``c1_rel``
    following it) and ``priors`` (its tolerances), and defines
    ``likelihood_residual(theta (ndim,)) -> (m,)``, whose squared norm
    times ``LIKELIHOOD_SCALE`` is ``-log L``."""

    #: Index of ``c0_rel`` in ``theta`` (None: no pendulum pair sampled).
    pendulum_index = None
    priors = Priors()
    #: ``-log L = LIKELIHOOD_SCALE * |likelihood_residual|^2``.
    LIKELIHOOD_SCALE = 1.0

    def log_prior(self, theta):
        """Flat strictly inside the bounds, -inf outside; with the pendulum's
        stated prior (:func:`bayescal.core.response.pendulum.log_prior`), shape (W,)."""
        theta = np.atleast_2d(theta)
        lo, hi = self.bounds()
        lp = np.where(np.all((theta > lo) & (theta < hi), axis=1), 0.0, -np.inf)
        i = self.pendulum_index
        if i is not None:
            lp = lp + pendulum_log_prior(theta[:, i], theta[:, i + 1],
                                         self.priors.period_tolerance,
                                         self.priors.damping_tolerance)
        return lp

    def log_prob(self, theta):
        """Vectorised log posterior: theta (W, ndim) -> (W,); the likelihood
        is evaluated only where the prior is positive."""
        theta = np.atleast_2d(theta)
        lp = self.log_prior(theta)
        out = np.full(theta.shape[0], -np.inf)
        ok = np.isfinite(lp)
        if ok.any():
            out[ok] = lp[ok] + self.log_likelihood(theta[ok])
        return out

    def prior_residual(self, theta):
        """Rows whose squared norm times ``LIKELIHOOD_SCALE`` is minus the
        log of the pendulum's prior without its Jacobian: appended to the
        likelihood's residual, least squares finds the posterior's mode (up
        to the Jacobian) and its Gauss-Newton covariance includes the prior,
        so a band that fixes only damping/period still gives a proper start."""
        i = self.pendulum_index
        if i is None:
            return np.zeros(0)
        pr = self.priors
        return pendulum_prior_residual(theta[i], theta[i + 1], pr.period_tolerance,
                                       pr.damping_tolerance)[0] / np.sqrt(self.LIKELIHOOD_SCALE)

    def information(self, theta):
        """The likelihood's Fisher information at ``theta`` (Gauss-Newton:
        ``2 LIKELIHOOD_SCALE J^T J``, ``J`` the forward-difference Jacobian of
        ``likelihood_residual``), the noise model as set."""
        from ..core.fit import jacobian

        jac = jacobian(self.likelihood_residual, np.asarray(theta, float))
        return 2.0 * self.LIKELIHOOD_SCALE * jac.T @ jac

    def prior_sensitivity(self, samples, channel, n_eff=None):
        """:func:`bayescal.core.response.pendulum.reweighted_sensitivity` of the
        pendulum pair from the posterior's ``samples`` as ``{channel: ...}``
        (``n_eff`` the chain's smallest effective sample size; where the
        samples cannot decide, the likelihood's curvature,
        :meth:`information`, does); empty without a pendulum pair."""
        i = self.pendulum_index
        if i is None:
            return {}
        return reweighted_sensitivity(samples, {channel: (i, i + 1)},
                                      self.priors.period_tolerance,
                                      self.priors.damping_tolerance,
                                      information=self.information,
                                      n_eff=n_eff)


def prior_meta(priors):
    """``meta["response_prior"]``: the stated prior on period and damping."""
    return {"period_tolerance": priors.period_tolerance,
            "damping_tolerance": priors.damping_tolerance,
            "shape": "log-normal around the nominal values"}


def mark_set_by_prior(params, entries, channel):
    """Mark ``params`` entries (``period_s``, ``damping``,
    ``damping_over_period``) that :func:`bayescal.core.response.pendulum.set_by_prior_entries`
    names for ``channel`` with ``set_by_prior``, ``reason`` and ``action``."""
    for key, why in entries.items():
        cid, _, name = key.rpartition(":")
        if cid == channel and name in params:
            params[name].update({"set_by_prior": True, "reason": why["reason"],
                                 "action": why["action"]})
    return params
