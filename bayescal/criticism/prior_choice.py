"""Whether to leave the sensor's stated prior: the SUT's pendulum under the
sensor's tolerance (:class:`.effects.ResponseParameters`, or the channel
blocks of ``--fit-response all``) or the wide corner
(:class:`.effects.SutCorner`), decided by the data.

Two tests, in this order:

* **Prior-data conflict** (Box 1980; :meth:`.effects.SutCorner.prior_conflict`):
  at the wide corner's least-squares point, the distance from the
  metadata's pendulum under the likelihood's covariance plus the stated
  prior's, chi-square when the stated prior holds the truth. Below
  :data:`CONFLICT_P` the data put the stated prior in its tail and the wide
  corner is kept.
* **Evidence** (:func:`log_evidence_gain`, the Laplace approximation, whose
  Occam factor holds each prior's width): otherwise the alternative it
  prefers, and the wide corner only when its evidence passes as well.

The evidence alone would keep a prior the data conflict with: it rewards
the narrow prior for the parameter volume it spares, at a point that prior
itself puts in its tail (see docs/diagnose.md, "The response as the data
see it").
"""
from __future__ import annotations

import numpy as np

#: Alternatives chosen between when both pass the search's BIC threshold
#: (the same parameters under the sensor's stated prior and under a wide
#: one: the BIC, blind to priors, would always take the wider).
BY_EVIDENCE = ("response_parameters", "sut_corner")
#: Effects under a wide prior, kept only when their log evidence gain
#: (:func:`log_evidence_gain`) passes half the BIC threshold as well (``2
#: ln B > 10``, the same "very strong" on Kass and Raftery's scale: the BIC
#: charges the same for a parameter whatever the prior allows it, the
#: evidence charges for the prior's width), or the data conflict with the
#: stated prior (:data:`CONFLICT_P`).
WIDE_PRIOR = ("sut_corner",)
#: The level of the prior-data conflict test. Strict, since a switch made
#: in error gives up the stated prior's information on every channel: a
#: damping 13 % off the metadata's under a 5 % tolerance (2.6 of its sd on
#: each of three channels, p about 0.007) keeps the stated prior; 30 % off
#: (p below 1e-9) leaves it.
CONFLICT_P = 0.001


def log_evidence_gain(fit, score_entry, new_index):
    """The Laplace approximation to the log evidence a candidate adds to
    the current model: its log-likelihood gain (``score_entry``, under the
    candidate's noise model), its prior's log density at the least-squares
    point and the log volume of its posterior, ``k/2 ln 2 pi + 1/2 ln det
    C`` (``C`` the candidate's parameters' Laplace covariance). The Occam
    factor, prior density times posterior volume, holds each prior's width:
    a wide prior pays for the values it allows. ``fit``: the candidate's
    (model, theta, cov); its effect at ``new_index`` needs
    ``log_prior_density``."""
    model, theta, cov = fit
    effect, sl = model.effects[new_index], model.effect_slices[new_index]
    c = np.atleast_2d(cov[sl, sl])
    sign, logdet = np.linalg.slogdet(c)
    if sign <= 0:
        return -np.inf
    lp = float(effect.log_prior_density(np.asarray(theta)[sl][None])[0])
    return float(score_entry["delta_loglik"] + lp + 0.5 * c.shape[0] * np.log(2 * np.pi)
                 + 0.5 * logdet)


def prior_conflict(priors, fit, index):
    """``{"prior_conflict": {chi2, dof, p_value, level, conflict}}``: the
    wide corner's (effect ``index`` of ``fit``, a (model, theta, cov))
    test of the stated prior of ``priors`` (its period and damping
    tolerances; :meth:`.effects.SutCorner.prior_conflict`), ``conflict``
    true below :data:`CONFLICT_P`; ``{}`` where the metadata give no
    pendulum."""
    m, theta, cov = fit
    effect, sl = m.effects[index], m.effect_slices[index]
    out = effect.prior_conflict(np.asarray(theta)[sl], np.asarray(cov)[sl, sl],
                                (priors.period_tolerance, priors.damping_tolerance))
    if out is None or not np.isfinite(out["chi2"]):
        return {}
    return {"prior_conflict": dict(out, level=CONFLICT_P, conflict=out["p_value"] < CONFLICT_P)}


def conflicts(entry):
    """Whether a tried candidate's prior-data conflict test rejects the
    stated prior."""
    return bool(entry.get("prior_conflict", {}).get("conflict"))


def _passes(t, keep):
    if t["effect"] not in WIDE_PRIOR:
        return True
    if t.get("releases"):       # in place of fitted blocks: only where the stated prior fails
        return conflicts(t)
    return 2.0 * t["log_evidence_gain"] > keep or conflicts(t)


def by_evidence(good, keep):
    """``good`` (tried candidates with a score) less the effects of
    :data:`WIDE_PRIOR` that pass neither their evidence nor the conflict
    test (a wide corner in place of blocks that fit the pendulum under the
    stated prior, ``"releases"``, passes on a conflict only), and the
    alternatives of :data:`BY_EVIDENCE` not chosen when more than one of
    them passes ``keep`` (the BIC threshold): the wide corner where the data
    conflict with the stated prior, else the one the evidence prefers."""
    good = [t for t in good if _passes(t, keep)]
    alt = [t for t in good if t["effect"] in BY_EVIDENCE and t["delta_bic"] > keep]
    if len(alt) < 2:
        return good
    best = max(alt, key=lambda t: (conflicts(t), t["log_evidence_gain"]))
    return [t for t in good if t["effect"] not in BY_EVIDENCE or t is best]
