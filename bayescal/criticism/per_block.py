"""The search's hand-over from the per-block likelihood to the
errors-in-variables model (:func:`.search.search`).

A clock drift shows only in the time blocks, and the per-block likelihood
exists for the quiet model alone: it has no term for the reference's own
self-noise. When the diagnosis has named that noise (:mod:`.reference_noise`)
and a drift is a candidate, the search starts on the per-block likelihood;
the reference's noise dilutes the transfer function there, by its coherence
deficit band by band, and a response effect (the SUT's corner, a pole) takes
that dilution up and gains BIC for physics that is not there. So what the
per-block search keeps besides a drift is set aside (:func:`set_aside`):
a drift named is carried over to the errors-in-variables model alone
(:func:`drift_under_eiv`) and the search goes on there; no drift named, and
the search runs again under the errors-in-variables model
(:func:`search_again`). Either way every effect but the drift is scored with
the reference's noise modelled.
"""
from __future__ import annotations

import numpy as np

from . import effects as catalogue
from ..core.model import forward_jacobian, EIVModel
from ..core.fit import least_squares_fit
from .locate import overdispersion

#: Why effects kept on the per-block likelihood are scored again.
SET_ASIDE = "kept on the per-block likelihood, which lacks the reference's noise"


def set_aside(steps):
    """The search's ``steps`` with their ``kept`` entries marked
    ``set_aside`` (with :data:`SET_ASIDE` as their ``reason``)."""
    return [[{("set_aside" if k == "kept" else k): v for k, v in t.items()}
             | ({"reason": SET_ASIDE} if "kept" in t else {}) for t in step] for step in steps]


def search_again(out, eiv, log=None):
    """Whether the search's result ``out`` ``(model, theta, cov, steps)``
    holds effects kept on the per-block likelihood that the errors-in-
    variables model ``eiv`` must score again: it kept effects and none is a
    clock drift (a drift named is carried over by :func:`drift_under_eiv`).
    False without ``eiv``. Where the budget stopped the search, the caller
    keeps none of them (nothing is left to score them with)."""
    model = out[0]
    if eiv is None or not model.effects or any(e.name == "clock_drift" for e in model.effects):
        return False
    if log:
        log(f"  {', '.join(e.name for e in model.effects)} set aside: {SET_ASIDE}")
    return True


def stopped(steps):
    """Whether the budget stopped the search whose ``steps`` these are."""
    return bool(steps and steps[-1] and steps[-1][-1].get("stopped"))


def drift_under_eiv(eiv, model, theta, cov, log=None, base=None):
    """A clock drift named on the per-block likelihood (``model``, which has
    no errors-in-variables treatment of the reference's self-noise: its
    dilution of the transfer function by that noise would be left for
    further effects to take up) carried over to the errors-in-variables
    model ``eiv``: the drift's rate is taken out of the spectra
    (:func:`.effects.drift_corrected`) and its offset at mid-record stays a
    parameter (:class:`.effects.CorrectedDrift`). The effects kept before
    it are left out (:data:`SET_ASIDE`): the search scores them again.
    ``base``: the channel blocks' part of ``theta`` in ``eiv``'s layout
    (the search's own blocks back where an effect set aside had taken up
    their pendulum; ``model``'s by default).

    The rate is the per-block estimate: only the time blocks see it (the
    record's totals under ``eiv`` do to second order only, through the
    decoherence). Its standard deviation is the per-block one scaled as a
    quasi-likelihood's, by the square root of the dispersion the per-block
    model leaves (:func:`overdispersion`: the median standardised misfit,
    at least 1), the reference's noise that model lacks included.
    Returns (model, theta, cov)."""
    k = next(i for i, e in enumerate(model.effects) if e.name == "clock_drift")
    drift, sl = model.effects[k], model.effect_slices[k]
    tau, ppm = (float(x) for x in np.asarray(theta)[sl])
    phi = overdispersion(model, theta)
    sd = float(np.sqrt(cov[sl, sl][1, 1] * phi))
    if log and len(model.effects) > 1:
        log(f"  {', '.join(e.name for e in model.effects if e is not drift)} set aside: "
            f"{SET_ASIDE}")
    if base is None:
        base = np.asarray(theta)[:sum(b.n_params for b in model.blocks)]
    sp = catalogue.drift_corrected(model.spectra, drift, ppm)
    eff = [catalogue.CorrectedDrift(drift.rows, ppm, sd, dispersion=phi)]
    m = EIVModel(sp, eiv.ref_vectors, eiv.blocks, eiv.priors, ref_noise=eiv.ref_noise,
                 effects=eff, known_noise=getattr(eiv, "known_noise", None))
    m.inflation_floor = eiv.inflation_floor
    th, c = least_squares_fit(m, np.concatenate([base, [tau]]),
                              jac=forward_jacobian(m, matmul=True))
    if log:
        log(f"  clock_drift carried to the errors-in-variables model: {ppm:.4g} +- {sd:.2g} ppm "
            f"(per-block dispersion {phi:.3g})")
    return m, th, c
