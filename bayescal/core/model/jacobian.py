"""Forward-difference Jacobian of a model's whitened residual with all
``ndim + 1`` points in one vectorised residual call.

scipy's ``"2-point"`` makes one residual call per parameter; the model's
residual is vectorised over parameter points (emcee's walkers), so one call
for all columns costs little more than one point (five times faster for the
base model, :mod:`bayescal.core.fit.modes`; twelve parameters of a diagnose search's
per-time-block model, :mod:`bayescal.criticism.search`). Steps are scipy's
size, ``sqrt(eps) max(1, |theta|)``, always forward; the columns agree
with scipy's to the differences' rounding, not to the bit, so a fit whose
numbers must not move keeps ``"2-point"``.

:func:`least_squares_objective` is what least squares minimises: the
whitened residual with the pendulum priors' rows appended.
"""
from __future__ import annotations

import numpy as np

from ..response import pendulum
from .likelihood import Model


def forward_jacobian(model, matmul=False):
    """A ``jac`` callable for :func:`scipy.optimize.least_squares` on
    ``model.whitened_residual`` (args ``(factors,)``): :class:`Model`'s and
    the errors-in-variables model's; scipy's ``"2-point"`` for any other.

    ``matmul``: whiten (``la^H R lb``) with batched matrix products instead
    of the three-operand einsum, which loops over all five indices at once
    (several times slower on a per-time-block model); the columns differ in
    rounding, so the mode search (:mod:`bayescal.core.fit.modes`), whose optima a fit reports,
    keeps the einsum."""
    from .eiv import EIVModel

    if isinstance(model, EIVModel) and type(model).whitened_residual is EIVModel.whitened_residual:
        return _eiv_jacobian(model)
    if type(model).whitened_residual is not Model.whitened_residual:
        return "2-point"

    def jac(theta, factors):
        la, lb = factors
        h = np.sqrt(np.finfo(float).eps) * np.maximum(1.0, np.abs(theta))
        r = model.residual_blocks(np.vstack([theta, theta + np.diag(h)]))
        if matmul:
            z = np.ascontiguousarray(la.conj().transpose(0, 2, 1)) @ r @ lb
        else:
            z = np.einsum("bji,wgbjk,gbkl->wgbil", la.conj(), r, lb)
        z = z.reshape(z.shape[0], -1)
        r = np.concatenate([z.real, z.imag], axis=1)
        return ((r[1:] - r[0]) / h[:, None]).T
    return jac


def _eiv_jacobian(model):
    """The same for :class:`bayescal.core.model.eiv.EIVModel`: its statistic is
    vectorised over points too (the profiled noise coefficients solved per
    point), whitened as :meth:`EIVModel.whitened_residual` does."""
    def jac(theta, factors):
        h = np.sqrt(np.finfo(float).eps) * np.maximum(1.0, np.abs(theta))
        x, _ = model.statistic(np.vstack([theta, theta + np.diag(h)]))     # (W, B, 2m)
        z = (np.swapaxes(factors, -1, -2)[None] @ x[..., None])[..., 0] / np.sqrt(2.0)
        r = z.reshape(z.shape[0], -1)
        return ((r[1:] - r[0]) / h[:, None]).T
    return jac


def least_squares_objective(model, jac):
    """``(fun, jac)`` for :func:`scipy.optimize.least_squares` on ``model``
    (args ``(factors,)``): the whitened residual and, for each channel whose
    period and damping are free, the pendulum prior's rows appended
    (:func:`bayescal.core.response.pendulum.prior_residual`), and those of each
    effect with a ``prior_residual`` (see :class:`bayescal.core.model.effect.Effect`), so that a direction the
    data hardly fix stays where the prior puts it and ``2 J^T J`` is the
    posterior's Laplace precision. ``jac``: the whitened residual's (a
    callable or scipy's ``"2-point"``)."""
    pr = model.priors
    blocks = [sr.start for b, (_, sr) in zip(model.blocks, model.slices) if b.free == "all"]
    # an effect with a proper prior gives its rows too (Effect.prior_residual)
    effects = [(e, sl) for e, sl in zip(getattr(model, "effects", ()),
                                        getattr(model, "effect_slices", ()))
               if hasattr(e, "prior_residual")]
    if not blocks and not effects:
        return model.whitened_residual, jac

    def prior_rows(theta):
        rows, out = [], []
        for i in blocks:
            r, d = pendulum.prior_residual(theta[i], theta[i + 1], pr.period_tolerance,
                                           pr.damping_tolerance)
            full = np.zeros((2, theta.size))
            full[:, i:i + 2] = d
            rows.append(r)
            out.append(full)
        for e, sl in effects:
            r, d = e.prior_residual(theta[sl])
            full = np.zeros((r.size, theta.size))
            full[:, sl] = d
            rows.append(r)
            out.append(full)
        return np.concatenate(rows), np.vstack(out)

    def fun(theta, factors):
        return np.concatenate([model.whitened_residual(theta, factors), prior_rows(theta)[0]])
    if not callable(jac):
        return fun, jac

    def both(theta, factors):
        return np.vstack([jac(theta, factors), prior_rows(theta)[1]])
    return fun, both
