"""Least squares: the one place :func:`scipy.optimize.least_squares` is
called, for every fit of bayescal (pair fits, mode search, held parameters,
coil calibrations, the criticism's refits).

Two methods:

* ``"lm"``: Levenberg-Marquardt, unbounded, falling back to the bounded
  trust-region method from its end point clipped into the box only when it
  leaves the box. The trust-region method alone stalls when the start is
  exactly zero in the tangent-plane coordinates of an axis (its first trust
  radius is ``|x0| = 0``); LM's trial steps are unbounded, and one far
  outside the box can overflow a response (exp of a large log-gain): LM
  rejects that residual, so the floating-point warnings are silenced.
* ``"trf"``: the bounded trust-region method.

:func:`refine` is a fit's least squares with its noise model re-estimated
after each pass; :func:`covariance` the inverse of the Gauss-Newton
information at the end point.
"""
from __future__ import annotations

import contextlib

import numpy as np
from scipy.optimize import least_squares

from ...errors import BudgetSpent, FitError

#: Tolerances of a refinement's passes.
TIGHT = dict(xtol=1e-12, ftol=1e-12, gtol=1e-12)


def solve(fun, x0, lo=-np.inf, hi=np.inf, method="trf", jac="2-point", args=(), budget=None,
          **kw):
    """One least-squares run of ``fun(x, *args)`` from ``x0`` in the box
    ``[lo, hi]`` by ``method`` (module docstring); ``kw`` go to scipy
    (tolerances, ``x_scale``, ``max_nfev``). Returns scipy's result.

    ``budget``: a :class:`bayescal.core.budget.Budget`, active during the
    run (the model's evaluations count into it) and checked before each
    evaluation of ``fun``; once spent the run ends at the best point it has
    evaluated (the result's ``status`` is then ``-3``, its ``message`` the
    budget's note)."""
    if budget is None:
        return _solve(fun, x0, lo, hi, method, jac, args, **kw)
    tracked = _Best(fun, budget)
    try:
        with budget.active():
            return _solve(tracked, x0, lo, hi, method, jac, args, **kw)
    except BudgetSpent as spent:
        return tracked.result(x0, lo, hi, str(spent))


class _Best:
    """``fun`` that checks ``budget`` before each evaluation and keeps the
    point of the smallest finite squared residual it has returned."""

    def __init__(self, fun, budget):
        self.fun, self.budget = fun, budget
        self.x, self.cost = None, np.inf

    def __call__(self, x, *args):
        self.budget.check()
        r = self.fun(x, *args)
        cost = float(np.sum(np.square(r)))
        if np.isfinite(cost) and cost < self.cost:
            self.x, self.cost = np.array(x, float), cost
        return r

    def result(self, x0, lo, hi, message):
        """scipy's result fields for the best point (``x0`` when none was evaluated)."""
        from scipy.optimize import OptimizeResult
        x = np.clip(x0 if self.x is None else self.x, lo, hi)
        return OptimizeResult(x=x, cost=0.5 * self.cost, status=-3, success=False,
                              message=message)


def _solve(fun, x0, lo, hi, method, jac, args, **kw):
    if method == "lm":
        with np.errstate(over="ignore", invalid="ignore", divide="ignore"):
            res = least_squares(fun, x0, jac=jac, args=args, method="lm", **kw)
        if np.any(res.x < lo) or np.any(res.x > hi):
            res = least_squares(fun, np.clip(res.x, lo + 1e-9, hi - 1e-9), jac=jac, args=args,
                                bounds=(lo, hi), method="trf", **kw)
        return res
    return least_squares(fun, x0, jac=jac, args=args, bounds=(lo, hi), method="trf", **kw)


def jacobian(fun, x, jac="2-point", args=(), bounds=None, **kw):
    """The Jacobian of ``fun(x, *args)`` at ``x`` as least squares evaluates
    it (one evaluation, no step): unbounded, or inside ``bounds`` (lo, hi)
    by the trust-region method with ``kw`` (e.g. ``x_scale``)."""
    if bounds is None:
        return least_squares(fun, x, jac=jac, args=args, method="lm", max_nfev=1).jac
    return least_squares(fun, x, jac=jac, args=args, bounds=bounds, method="trf", max_nfev=1,
                         **kw).jac


def covariance(jac, scale=2.0):
    """``(scale J^T J)^-1``, symmetrised: the Laplace covariance of a
    least-squares point whose ``-log L`` is ``scale / 2`` times the squared
    residual norm."""
    try:
        cov = np.linalg.inv(scale * jac.T @ jac)
    except np.linalg.LinAlgError as exc:
        raise FitError("the least-squares point is degenerate (singular information)") from exc
    return 0.5 * (cov + cov.T)


def refine(fun, theta0, lo, hi, reestimate, passes, *, noise_args=tuple, method="lm",
           jac="2-point", scale=2.0, reestimate_first=True, budget=None, **kw):
    """Least squares with the noise model re-estimated after each pass.

    From ``theta0`` clipped into ``[lo, hi]``: ``reestimate(theta)`` (first
    too, unless ``reestimate_first`` is False: the noise model is already
    set), then ``passes`` times a :func:`solve` of ``fun(x, *noise_args())``
    by ``method`` at :data:`TIGHT` tolerances (``kw``: ``x_scale``) and the
    noise model re-estimated at its end point. Returns ``(theta,
    covariance)``, the covariance :func:`covariance` of the Jacobian at
    ``theta`` (unbounded for "lm", in the box for "trf").

    ``budget`` (:func:`solve`): once spent, no further pass runs; the
    point is the best one evaluated. The noise model's re-estimates and
    the final Jacobian count into it too (it is active throughout; they
    run whatever is left, so that the point has its noise model and
    covariance).
    """
    with (budget.active() if budget is not None else contextlib.nullcontext()):
        theta = np.clip(np.asarray(theta0, float), lo + 1e-9, hi - 1e-9)
        if reestimate_first:
            reestimate(theta)
        for _ in range(passes):
            res = solve(fun, theta, lo, hi, method=method, jac=jac, args=noise_args(),
                        budget=budget, **TIGHT, **kw)
            if not np.isfinite(res.x).all():
                raise FitError("least squares left the finite parameter range (a non-finite "
                               "residual); check the responses and the band")
            theta = res.x
            reestimate(theta)
            if budget is not None and budget.spent():
                break
        j = jacobian(fun, theta, jac=jac, args=noise_args(),
                     **({} if method == "lm" else dict(bounds=(lo, hi), **kw)))
    return theta, covariance(j, scale)
