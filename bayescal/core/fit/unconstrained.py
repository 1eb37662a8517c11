"""A gain the data do not constrain: found early, held at its nominal value,
and said so ("set by the prior"). Period and damping have a stated prior
and their own test (:mod:`bayescal.core.response.pendulum`); this module concerns the
parameters with a box prior, the log-uniform gain.

Two checks, both against the prior's own spread (the standard deviation of
the uniform prior on ``log gain``):

* **before sampling**, from the least-squares curvature: the Laplace standard
  deviation of each gain, the other free parameters marginalised, at the
  nominal response (the prior's centre; angles as fitted). When it is at
  least ``EARLY_RATIO`` of the prior's, the data hardly narrow the prior;
  the least constrained such parameter is held at its nominal value, the
  others' curvature is recomputed given it, and so on. Held parameters cost
  the sampler nothing;
* **after sampling**, for what was sampled: a posterior standard deviation of
  at least ``LATE_RATIO`` of the prior's, or a 95 % interval reaching within
  ``BOUND_FRACTION`` of the prior's width from a bound (a gain pinned at 10
  times nominal: the data want a value the prior excludes).

Either way the parameter is listed in ``result.meta.set_by_prior`` and
the corrected StationXML keeps its nominal value. The least squares of the
free parameters given the held ones runs within a work budget of its own
(:data:`REFIT_WORK`), as the pair fit's other stages do
(:mod:`bayescal.core.budget`).
"""
from __future__ import annotations

import numpy as np

from ..progress import stage
from ..response import pendulum
from ..model.jacobian import least_squares_objective
from .leastsq import TIGHT, jacobian, solve

#: Laplace sd / prior sd at or above which a parameter is held at nominal.
EARLY_RATIO = 0.5
#: Posterior sd / prior sd at or above which a sampled parameter is flagged.
LATE_RATIO = 0.5
#: A 95 % interval this close to a prior bound (fraction of the prior's width) is pinned.
BOUND_FRACTION = 0.01
#: Work budget (:data:`bayescal.core.budget.UNIT`) of the least squares of the
#: free parameters once some are held: that of the pair fit's least squares
#: (:data:`bayescal.core.budget.LEAST_SQUARES_WORK`), which starts further away.
REFIT_WORK = 30_000


def prior_box(model):
    """(lo, hi) prior bounds per parameter (infinite for angles)."""
    return prior_bounds(model)


def nominal_theta(model):
    """Per parameter its nominal value in model coordinates (NaN for angles)."""
    out = np.full(model.ndim, np.nan)
    for b, (_, sr) in zip(model.blocks, model.slices):
        idx = np.arange(model.ndim)[sr]
        if b.free == "gain":
            out[idx[0]] = np.log(b.family.gain)
        elif b.free == "all":
            out[idx] = [1.0, 1.0, np.log(b.family.gain)]
    return out


def information(model, theta):
    """Fisher information ``2 J^T J`` of the whitened residual at ``theta``
    (``-log L`` is its squared norm), the noise model as set."""
    jac = jacobian(model.whitened_residual, theta, args=(model.noise.cholesky(),))
    return 2.0 * jac.T @ jac


def pendulum_precision(model):
    """(ndim, ndim) precision of the pendulum priors at the nominal response
    (:func:`bayescal.core.response.pendulum.prior_precision`; zero elsewhere): added
    to the likelihood's information wherever a curvature stands for the
    posterior's."""
    q = np.zeros((model.ndim, model.ndim))
    pr = model.priors
    for b, (_, sr) in zip(model.blocks, model.slices):
        if b.free == "all":
            idx = [sr.start, sr.start + 1]
            q[np.ix_(idx, idx)] = pendulum.prior_precision(1.0, 1.0, pr.period_tolerance,
                                                           pr.damping_tolerance)[0]
    return q


def early_holds(model, theta, ratio=EARLY_RATIO):
    """Indices of response parameters to hold at nominal, from the curvature
    at the nominal response (angles from the least-squares point ``theta``);
    returns ``{index: ratio}`` (the
    Laplace sd over the prior sd when it was chosen)."""
    lo, hi = prior_box(model)
    prior_sd = (hi - lo) / np.sqrt(12.0)
    # the curvature at the prior's centre (nominal response, angles as
    # fitted), not at the least-squares point: along a ridge the latter lands
    # anywhere, often where the ridge bends and looks sharp while the
    # posterior is as wide as the prior (measured: a 120-s sensor in 0.2-2 Hz)
    nominal = nominal_theta(model)
    fisher = information(model, np.where(np.isfinite(nominal), nominal, theta))
    fisher = fisher + pendulum_precision(model)      # the pendulum's prior is proper
    held = {}
    while True:
        free = [j for j in range(model.ndim) if j not in held]
        cov = np.linalg.pinv(fisher[np.ix_(free, free)], hermitian=True)
        sd = np.sqrt(np.maximum(np.diag(cov), 0.0))
        r = np.where(np.isfinite(prior_sd[free]), sd / prior_sd[free], 0.0)
        k = int(np.argmax(r)) if r.size else 0
        if not r.size or r[k] < ratio:
            break
        held[free[k]] = float(r[k])
    return held


def prior_bounds(model):
    """(lo, hi) of every parameter under the priors (infinite for the angles)."""
    return model.bounds()


class Held:
    """``model`` with some parameters held at given values: what the sampler
    sees (``ndim``, ``log_prob``, ``names``) has only the others."""

    def __init__(self, model, held_values):
        self.model = model
        self.held = dict(held_values)
        self.free = [j for j in range(model.ndim) if j not in self.held]
        self.ndim = len(self.free)
        self.names = [model.names[j] for j in self.free]

    def expand(self, theta):
        theta = np.atleast_2d(theta)
        out = np.empty((theta.shape[0], self.model.ndim))
        out[:, self.free] = theta
        for j, v in self.held.items():
            out[:, j] = v
        return out

    def log_prob(self, theta):
        return self.model.log_prob(self.expand(theta))

    def refit(self, theta_full, budget=None):
        """Least-squares point of the free parameters given the held ones,
        and its Laplace covariance. Returns ``(theta_full, cov_free)``.
        ``budget``: a :class:`bayescal.core.budget.Budget`; once spent the
        point is the best one evaluated (:func:`.leastsq.solve`)."""
        lo, hi = prior_box(self.model)
        lo, hi = lo[self.free], hi[self.free]
        fac = self.model.noise.cholesky()
        x0 = np.clip(np.asarray(theta_full, float)[self.free], lo + 1e-9, hi - 1e-9)

        objective, _ = least_squares_objective(self.model, "2-point")

        def fun(x):
            return objective(self.expand(x)[0], fac)

        res = solve(fun, x0, lo, hi, method="trf", budget=budget, **TIGHT)
        full = self.expand(res.x)[0]
        fisher = (information(self.model, full)
                  + pendulum_precision(self.model))[np.ix_(self.free, self.free)]
        cov = np.linalg.pinv(fisher, hermitian=True)
        return full, 0.5 * (cov + cov.T)


def late_flags(model, samples, skip=()):
    """Sampled response parameters the prior set: ``{index: reason}``.
    ``samples`` (N, ndim) in model coordinates; ``skip`` indices held."""
    lo, hi = prior_box(model)
    width = hi - lo
    out = {}
    for j in range(model.ndim):
        if j in skip or not np.isfinite(width[j]):
            continue
        x = samples[:, j]
        r = np.std(x) / (width[j] / np.sqrt(12.0))
        q_lo, q_hi = np.percentile(x, [2.5, 97.5])
        if q_hi > hi[j] - BOUND_FRACTION * width[j]:
            out[j] = "pinned at the prior's upper bound: the data want a value the prior excludes"
        elif q_lo < lo[j] + BOUND_FRACTION * width[j]:
            out[j] = "pinned at the prior's lower bound: the data want a value the prior excludes"
        elif r >= LATE_RATIO:
            out[j] = f"posterior nearly as wide as the prior (sd {r:.2f} of the prior's)"
    return out


def describe_held(model, held):
    """``meta["set_by_prior"]`` entries for parameters held before sampling."""
    nominal = nominal_theta(model)
    return {model.names[j]: {"action": "held at nominal", "nominal": _physical(model.names[j],
                                                                                nominal[j]),
                             "reason": f"the data do not constrain it: least-squares sd "
                                       f"{r:.2f} of the prior's (threshold {EARLY_RATIO:g}); "
                                       "held at its nominal value while sampling, the other "
                                       "parameters are conditional on it"}
            for j, r in held.items()}


def describe_late(model, flags):
    """``meta["set_by_prior"]`` entries for flagged sampled parameters."""
    nominal = nominal_theta(model)
    return {model.names[j]: {"action": "sampled; nominal kept in the corrected StationXML",
                             "nominal": _physical(model.names[j], nominal[j]), "reason": why}
            for j, why in flags.items()}


def _physical(name, value):
    return float(np.exp(value)) if name.split(":")[-1].startswith("log_") else float(value)


def hold_unconstrained(model, theta_ls, cov, budget=None):
    """Before sampling: hold the parameters :func:`early_holds` finds at
    nominal. Returns ``(target, start, cov, theta_ls, held_meta)``: what to
    sample (the model itself when nothing is held), its start and Laplace
    covariance, the (re-fitted) least-squares point in full coordinates and
    the ``set_by_prior`` entries. ``budget``: the refit's work budget
    (:meth:`Held.refit`); the refit says its progress as a stage
    (:mod:`bayescal.core.progress`)."""
    if not any(b.free == "all" for b in model.blocks):
        return model, theta_ls, cov, theta_ls, {}
    held = early_holds(model, theta_ls)
    if not held:
        return model, theta_ls, cov, theta_ls, {}
    nominal = nominal_theta(model)
    target = Held(model, {j: nominal[j] for j in held})
    with stage("refit with parameters held", budget) as st:
        theta_full, cov_free = target.refit(theta_ls, budget=budget)
        st.result = (f"{len(held)} held at nominal, {target.ndim} refitted"
                     + (", BUDGET SPENT" if budget is not None and budget.ended_by else ""))
    return target, theta_full[target.free], cov_free, theta_full, describe_held(model, held)


def full_samples(target, samples):
    """Samples in the model's full coordinates."""
    return target.expand(samples) if isinstance(target, Held) else samples
