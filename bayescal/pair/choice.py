"""The last step of a pair fit: the frozen
:class:`~bayescal.result.record.Result`. The sensors' self-noise, the
reference's metadata tolerance and the flags on what the prior set are
applied here, before the Result is built (the tolerance and the flags to
the headline's values; the self-noise split to the fit's, the pair model
it is made for).

Which estimates are reported (the headline, ``result.meta.headline``): the
criticism's improved model's when its verdict is ``improved`` (the fit's
model misfits the recordings and modelling the named effects moves the
estimates); the fit's otherwise (it fits, its misfit moves nothing, or the
misfit stays unexplained). A fit the verdict rejects is kept in one place,
``result.rejected`` (result.json's ``rejected_fit``: its channels,
convergence and model check); the improved model's Result, when the
criticism made one, is ``result.improved`` either way.
"""
from __future__ import annotations

import warnings
from dataclasses import replace

from ..core.response import (MIN_KISH, judged_sensitivity, meta_entry, set_by_prior_entries,
                             sut_priors, widen_responses)
from ..core.selfnoise import for_fit
from ..errors import InputWarning
from .caller import caller_stacklevel
from .response_curve import relative_response


def self_noise(state, data, *, fit_response, seed=0):
    """The ``(self_noise, sensor_order)`` entries of the fit ``state`` of
    ``data`` (:func:`bayescal.core.selfnoise.pair_noise.for_fit`)."""
    rn = state.meta.reference_noise or {}
    return for_fit(state.model, state.full_samples, ref_noise=rn.get("mode"),
                   free=fit_response, seed=seed,
                   ids=(data.spectra.sut_ids, data.spectra.ref_ids),
                   flat=data.ref_flat or (data.sut_flat and fit_response == "none"),
                   sut_placeholder=data.sut_flat,
                   poorly_separated="note" in rn.get("separation", {}))


def _tolerated(state, data, tolerance, seed, stated=None):
    """(responses, meta, info) of ``state`` with the reference's metadata
    ``tolerance`` integrated out of its responses, weighed by the SUT's
    ``stated`` prior (a :class:`~bayescal.core.priors.Priors`; None: the
    model's own) against the one the fit sampled with
    (:mod:`bayescal.core.response.reference_tolerance`; ``info`` per
    channel its Kish share and effective draws); as they are when the
    tolerance is 0."""
    if not tolerance:
        return state.response, state.meta, {}
    rows = {str(cid): k for k, cid in enumerate(data.fitted.sut_ids)}
    sut_vectors = [data.sut_vectors[rows[cid]] for cid in state.channel_ids]
    response, info = widen_responses(state.response, state.channel_ids, sut_vectors=sut_vectors,
                                     ref_vectors=data.ref_vectors,
                                     ref_families=data.ref_families, tolerance=tolerance,
                                     seed=seed, priors=sut_priors(state.model, stated),
                                     sampled=sut_priors(state.model))
    own = getattr(state.model, "priors", None)
    tols = lambda p: (p.period_tolerance, p.damping_tolerance)   # noqa: E731
    wider = stated is not None and own is not None and tols(own) != tols(stated)
    entry = meta_entry(tolerance, info, tols(own) if wider else None)
    return response, state.meta.replace(reference_tolerance=entry), info


def stated_priors(state):
    """The priors stated for the fit ``state``: its model's, with the period
    and damping tolerances of its ``meta.response_prior`` where it sampled
    with others (:func:`bayescal.pair.fitting.stated_prior`); None without
    a model."""
    own = getattr(state.model, "priors", None)
    rp = state.meta.response_prior or {}
    if own is None or "sampled_with" not in rp:
        return own
    return replace(own, period_tolerance=rp["period_tolerance"],
                   damping_tolerance=rp["damping_tolerance"])


def _tolerance_flags(head, response, info, stated=None):
    """The meta entries of ``head`` that change once the reference's
    tolerance is in its ``response`` (:func:`judged_sensitivity`: what the
    prior sets among the reported values), ``{}`` when nothing is judged;
    warns (:class:`~bayescal.errors.InputWarning`) when the SUT's prior
    leaves few of the reference's draws effective."""
    low = {cid: v for cid, v in info.items() if v["kish_fraction"] < MIN_KISH}
    if low:
        warnings.warn(
            "the reference's tolerance is much wider than the SUT's prior allows: "
            + ", ".join(f"{cid} keeps {100 * v['kish_fraction']:.2g} % of the reference's draws "
                        f"({v['effective_draws']:.0f} effective)" for cid, v in low.items())
            + "; " + ("its" if len(low) == 1 else "their")
            + " period and damping rest on the SUT's prior and on those draws",
            InputWarning, stacklevel=caller_stacklevel())
    if head.model is None or not head.meta.prior_sensitivity:
        return {}
    ess = head.convergence.ess_min
    n_eff = {cid: min(ess, v["effective_draws"]) if ess else v["effective_draws"]
             for cid, v in info.items()}
    sens = judged_sensitivity(response, sut_priors(head.model, stated), n_eff)
    entries = dict(head.meta.set_by_prior or {})
    for cid in sens:
        for name in ("period_s", "damping", "damping_over_period"):
            entries.pop(f"{cid}:{name}", None)
    entries.update(set_by_prior_entries(sens))
    return {"set_by_prior": entries, "prior_sensitivity": {**head.meta.prior_sensitivity,
                                                           **sens}}


def _reported(head, data, tolerance, seed, stated):
    """(responses, meta) the headline ``head`` reports: the tolerance in
    (:func:`_tolerated`), the flags on what the prior set judged on them."""
    response, meta, info = _tolerated(head, data, tolerance, seed, stated)
    if tolerance:
        meta = meta.replace(**_tolerance_flags(head, response, info, stated))
    return response, meta


def headline_is_improved(criticism):
    """Whether the verdict of ``criticism`` (a
    :class:`~bayescal.criticism.verdict.Criticism`) chooses its improved
    model's estimates for the headline: verdict ``improved`` and an
    improved model that was sampled."""
    return criticism.improved is not None and criticism.summary.get("verdict") == "improved"


def headline_entry(criticism):
    """``meta.headline``: under which model the reported estimates are and
    why: ``model`` ("fit" or "improved"), ``effects`` (the effects the
    headline's model holds: none for the fit), ``label`` (them in words,
    never empty for the improved model), ``not_heading`` (effects the
    criticism named that the headline's model leaves out), ``verdict`` and
    ``why`` (the criticism's verdict and its words, when it ran) and, for
    the improved model, ``self_noise`` (whose self-noise the result gives)
    and ``reference_noise`` (True when it models the reference's noise)."""
    from ..criticism import words

    summary = criticism.summary or {}
    named = summary.get("effects", [])
    why = {"verdict": summary["verdict"], "why": summary.get("verdict_text", "")} \
        if summary.get("verdict") else {}
    if not headline_is_improved(criticism):
        # a verdict "fits" names what the fitted orientation already holds
        held = list(dict.fromkeys(e["name"] for e in named))
        fits = summary.get("verdict") == "fits"
        return {"model": "fit", "effects": held if fits else [], "label": "the fit's model",
                "not_heading": [] if fits else held, **why}
    effects = list(dict.fromkeys(criticism.improved.meta.effects or []))   # each once
    held = [e for e in named if e["name"] in effects]
    ref = bool(summary.get("reference_noise_modelled"))
    label = (words.names(held) or ("the reference's own self-noise" if ref else "")
             or words.names(named) or "effects the criticism modelled")
    return {"model": "improved", "effects": effects, "label": label,
            "not_heading": list(dict.fromkeys(e["name"] for e in named
                                              if e["name"] not in effects)),
            **why, "reference_noise": ref,
            "self_noise": "the fit's: the self-noise split and the sensor order are made for "
                          "the pair model without the improved model's effects"}


def rejected_entry(result):
    """result.json's ``rejected_fit``: what the verdict rejected (the fit
    under its own model): its channels, modes, orthogonality, model check
    and convergence."""
    return {"model": "fit", "channels": result.channels, "multimodal": result.meta.multimodal,
            "orthogonality_deg": result.orthogonality_deg, "adequacy": result.adequacy,
            "convergence": result.convergence.summary(result.names),
            "not_estimable": result.not_estimable}


def choose(state, criticism, *, data, fit_response=None, tolerance=None, seed=0, priors=None):
    """The :class:`~bayescal.result.record.Result` of a pair fit.

    Parameters
    ----------
    state : FitState
        From :func:`bayescal.pair.fitting.fit`.
    criticism : Criticism
        From :func:`bayescal.pair.criticism.criticise`: its verdict decides
        which model heads the Result (:func:`headline_is_improved`).
    data : PairData
        What the fit was made from (:func:`bayescal.pair.preparation.prepare`).
    fit_response : str or None
        What of the response was asked to be fitted; None: what the fit
        fitted (``state.meta.free_response``).
    tolerance : float or None
        The reference's metadata tolerance (``Priors.reference_tolerance``;
        None: the model's, 0 without one): the fit's and the improved model's
        responses carry it (the criticism judged the move between them on the
        data's own intervals); the prior flags judge the responses reported.
    seed : int
        Seed of the self-noise draws and of the tolerance's.
    priors : Priors or None
        The stated priors (the fit may sample with wider ones,
        :func:`bayescal.pair.fitting.sampling_priors`); None: :func:`stated_priors`.

    Returns
    -------
    Result
        The headline's: its channels, samples, responses, convergence, model
        check and meta (``headline`` says under which model); the
        self-noise and sensor order are the fit's (made for its model);
        ``rejected`` the fit the verdict rejected (empty when the fit is the
        headline); ``improved`` the improved model's Result or None;
        ``state`` the live fit ``state`` (the fit the criticism started
        from, also when the improved model heads the Result: the improved
        model's live state is ``improved.state``).
    """
    fit_response = fit_response or state.meta.free_response or "none"
    priors = priors or stated_priors(state)
    if tolerance is None:
        tolerance = getattr(getattr(state.model, "priors", None), "reference_tolerance", 0.0)
    improved = rejected = None
    if criticism.improved is not None:
        response, meta, _ = _tolerated(criticism.improved, data, tolerance, seed, priors)
        improved = criticism.improved.to_result(response=response, meta=meta)
    head = state
    if headline_is_improved(criticism):
        response, meta, _ = _tolerated(state, data, tolerance, seed, priors)
        rejected = rejected_entry(state.to_result(response=response, meta=meta))
        head = criticism.improved
    # the split is made for the pair model without effects (an improved model's
    # gain terms take up the incoherent power it reads, e.g. a noisier reference's)
    noise, order = self_noise(state, data, fit_response=fit_response, seed=seed)
    response, meta = _reported(head, data, tolerance, seed, priors)
    meta = meta.replace(headline=headline_entry(criticism))
    return head.to_result(response=response, meta=meta, self_noise=noise, sensor_order=order,
                          criticism=criticism.summary, improved=improved,
                          rejected=rejected or {}, state=state,
                          response_curve=relative_response(head, data))
