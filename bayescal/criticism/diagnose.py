"""Model criticism: locate the mismatch between the fitted model and the
recordings, name the physics left out, model it, show the fit improve.

Steps (see docs/diagnose.md):

1. **Locate** (:func:`.locate.locate`): per band and SUT channel, the standardised
   misfit ``v`` of the fitted model (whitened residual energy over its
   expectation; ``n_r v ~ Gamma(n_r, 1)`` under the model) and its p-value;
   cells below ``ALPHA / (B n_u)`` (Bonferroni) are a mismatch. Also the
   per-band complex ratio recorded/predicted (:func:`band_ratio`) and
   coherences, which the signatures in :mod:`.effects` read.
2. **Name and model**: every applicable catalogue effect is fitted as an
   extension of the current model (grid start over its parameter, then
   least squares) and scored against it by the BIC difference computed with
   *one* noise model (the extended model's, the base re-optimised under it):
   ``dBIC = 2 (logL_ext - logL_cur) - k ln n`` with ``n = 2 B n_u n_r`` real
   residual entries. The best effect with ``dBIC > BIC_KEEP`` is kept, and
   the search repeats from the extended model while it improves.
   A clock drift is fitted with the per-time-block likelihood (its rate and
   sign from the posterior). Orientation effects (reversed, swapped
   channels) are screened by comparing the free orientation fit with the
   metadata and scored by the BIC of the metadata's axes against the
   axes with those channels reversed or exchanged. Tilt noise is a nested
   extension of a model of the noise spectra (:mod:`.tilt`), scored
   by its own BIC.
3. **Show**: misfit per band before and after, score gains, effect
   parameters with credible intervals (MCMC on the final model, or its
   Laplace approximation), and how orientation and response moved.

"""
from __future__ import annotations

import numpy as np

from . import effects as catalogue, tilt, wiring
from .reference_noise import reference_noise_test
from ..core.model import treatment_meta as reference_noise_meta, EIVModel
from ..core.sampling import default_walkers, sample
from ..core.fit import (assemble_posterior, plugin_meta, least_squares_fit, describe_late,
                        information, late_flags)
from ..core.orientation import unit_vector
from ..core.threads import single_threaded_blas
from ..core.response import prior_sensitivity, set_by_prior_entries
from ..core.posterior import interval_summary
from ..result import Convergence
from .search import (BIC_KEEP, drift_candidate, effect_key, best_refit, restored, with_effects,
                     indistinguishable, orientation_score, search)
from .locate import band_ratio, block_timing, locate, ratio_weights, segment_timing
from .naming import without_effects, prune_overdispersed, timing_consistency, weak_effects
from .diagnosis import Diagnosis


def posterior_of(model, theta, cov, meta, not_estimable, free, *, seed=0, mcmc=True,
                 progress=False, n_laplace=4000, **sample_kw):
    """A :class:`~bayescal.core.posterior.state.FitState` of ``model`` (with effects) from MCMC
    (:func:`bayescal.core.sampling.mcmc.sample`, the pair fit's independence
    sampler unless ``move="de"`` is passed) or, with ``mcmc=False``, from its Laplace
    approximation (Gaussian at the least-squares point; stated in meta)."""
    if mcmc:
        chain = sample(model, theta, cov, seed=seed, progress=progress, **sample_kw)
        samples, lp = chain.samples, chain.log_prob
        conv = chain.convergence()
        trace = chain.trace
        meta = dict(meta, sampler=chain.sampler)
    else:
        rng = np.random.default_rng(seed)
        for shrink in (1.0, 0.25, 0.0625):      # draws outside the prior's support are dropped
            samples = rng.multivariate_normal(theta, cov * shrink, size=n_laplace)
            lp = model.log_prob(samples)
            if np.isfinite(lp).sum() >= n_laplace // 10:
                break
        samples, lp = samples[np.isfinite(lp)], lp[np.isfinite(lp)]
        if not len(samples):                    # no draw inside: the point itself
            samples = np.asarray(theta, float)[None]
            lp = model.log_prob(samples)
            meta = dict(meta, posterior_failed="no draw of its Gaussian approximation lies "
                                               "inside the prior's support")
        one = np.ones(model.ndim)
        conv = Convergence(tau=one, ess=one * len(samples), rhat=one, acceptance=1.0,
                           n_steps=0, n_walkers=0, burn=0, converged=True)
        trace = None
        meta = dict(meta, approximation="Laplace (Gaussian at the least-squares point), no MCMC",
                    sampler={"library": None, "draws": int(len(samples)),
                             "approximation": "Laplace (Gaussian at the least-squares point)"})
    meta = dict(meta, **prior_set(model, samples))
    return assemble_posterior(model, samples, lp, conv,
                              dict(meta, effects=[e.name for e in model.effects],
                                   plugin_weights=plugin_meta(model)),   # the final model's own
                              free, not_estimable=not_estimable, trace=trace)


def prior_set(model, samples):
    """The improved model's own ``set_by_prior`` (and ``prior_sensitivity``)
    meta entries, from its samples (model coordinates): sampled response
    parameters whose posterior is about as wide as their prior box or
    pinned at its bound (:func:`bayescal.core.fit.unconstrained.late_flags`),
    and the period, damping or damping/period the pendulum prior sets
    (:func:`bayescal.core.response.pendulum.prior_sensitivity`, with the
    likelihood's information of this model at the samples' median: its
    samples may be a Laplace approximation's, which reweighting to a
    doubled prior reads poorly). Nothing is held here: every parameter of
    the model is sampled."""
    med = np.median(samples, axis=0)
    out = describe_late(model, late_flags(model, samples))
    blocks = {b.channel_id: (sr.start, sr.start + 1)
              for b, (_, sr) in zip(model.blocks, model.slices) if b.free == "all"}
    sens = {}
    if blocks:
        pr = model.priors
        sens = prior_sensitivity(information(model, med), med, blocks,
                                 pr.period_tolerance, pr.damping_tolerance)
        out.update(set_by_prior_entries(sens))
    return {"set_by_prior": out, **({"prior_sensitivity": sens} if sens else {})}


# --- the whole diagnosis -------------------------------------------------------

def _nominal_vectors(meta, ids):
    nom = meta.nominal or {}
    return np.array([unit_vector(nom[c]["azimuth_deg"], nom[c]["dip_deg"]) for c in ids])


def _effect_entry(model, effect, sl, samples, step_score):
    phys = effect.physical(samples[:, sl])
    params = {k: interval_summary(v) for k, v in phys.items()}
    sbp = None
    if effect.name == "response_parameters":
        # what the prior sets is no measurement: left out, and said
        theta = np.median(samples, axis=0)
        sens = effect.prior_sensitivity(information(model, theta), theta, sl)
        params, sbp = catalogue.measured(params, sens)
    med = {k: v["median"] for k, v in params.items()}
    ids = [model.blocks[r].channel_id for r in effect.rows]
    if effect.name == "extra_pole":
        params["which"] = effect.which
    entry = {"name": effect.name, "channels": ids, "parameters": params,
             "score_gain": step_score,
             "explanation": effect.explain(med, sbp) if sbp else effect.explain(med)}
    if effect.name == "response_parameters":     # the metadata values the fit held
        entry["nominal"] = effect.nominal()
        entry["set_by_prior"] = sbp
    return entry


#: The improved model's chain: at least this much work (model evaluations,
#: :mod:`bayescal.core.budget`; 5 s of the criticism's
#: :data:`.verdict.WORK_PER_SECOND`) whatever is left of the criticism's
#: budget, and no chain shorter than this many steps (the Gaussian
#: approximation instead).
MIN_CHAIN_WORK, MIN_CHAIN_STEPS = 10_000, 300
#: Model evaluations a step of the improved model's sampler costs per walker,
#: its burn-in and adaptation spread over the kept steps (measured: 0.58 to
#: 0.60 on three pairs' improved models, 377 to 397 steps in all; below one
#: since proposals outside the prior cost no evaluation). The chain's
#: length is set from it before sampling, so a chain may spend more than
#: the work left (up to about 1 / 0.6 times), the same on every machine.
WORK_PER_WALKER_STEP = 0.6


def affordable_steps(model, work):
    """How many ensemble steps of ``model``'s sampler (its default walkers,
    :func:`bayescal.core.sampling.mcmc.sample`) ``work`` model evaluations pay for."""
    return int(work / (WORK_PER_WALKER_STEP * default_walkers(model.ndim)))


def orientation_effects(base, model0, th0, ids, sig=None):
    """Reversed or exchanged channels: the fitted axes against the metadata
    axes (a screen), each finding scored by the BIC of the metadata's axes
    against the axes with it (:func:`.search.orientation_score`). Returns
    the named ones as effect entries; scores go into ``sig``."""
    sig = {} if sig is None else sig
    if not base.meta.nominal:
        return []
    fitted = np.median(base.vectors, axis=0)
    fitted /= np.linalg.norm(fitted, axis=1, keepdims=True)
    nominal = _nominal_vectors(base.meta, ids)
    out = []
    findings = wiring.orientation_findings(fitted, nominal, ids)
    unfitted = {c: unit_vector(v["azimuth_deg"], v["dip_deg"])
                for c, v in base.meta.nominal.items()
                if c not in ids and c in (base.not_estimable or {})}
    findings += wiring.swaps_with_unfitted(fitted, nominal, ids, unfitted,
                                              {c for f in findings for c in f["channels"]})
    for f in findings:
        gain = orientation_score(model0, th0, nominal, f)
        sig[f"{f['name']}:{','.join(f['channels'])}"] = {"delta_bic": gain}
        if gain <= BIC_KEEP:
            continue
        ang = {ids[r]: interval_summary(np.degrees(np.arccos(np.clip(
            base.vectors[:, r] @ nominal[r], -1, 1))))
            for r in f["rows"]}
        out.append({"name": f["name"], "channels": f["channels"],
                    "parameters": {"angle_to_metadata_axis_deg": ang},
                    "score_gain": gain, "explanation": f["explanation"]
                    + "; the free orientation fit already models it"})
    return out


def diagnose(base, seed=0, mcmc=True, progress=False, log=None, budget=None, **sample_kw):
    """Diagnose a base fit.

    ``base`` is a :class:`~bayescal.core.posterior.state.FitState` (with
    ``.model`` and ``.theta_ls``): a pair fit's, :func:`bayescal.pair.fitting.fit`,
    or ``result.state`` of :func:`bayescal.calibrate`. ``budget``: a
    :class:`bayescal.core.budget.Budget` (active while this runs, so that
    the models' evaluations count into it): once spent no further candidate
    effect is tried (the diagnosis is then incomplete:
    ``Diagnosis.incomplete``), and the improved model's chain gets what is
    left of it (at least :data:`MIN_CHAIN_WORK`). None: no limit.
    Returns a :class:`Diagnosis`.

    BLAS runs single-threaded throughout (:func:`bayescal.core.threads.single_threaded_blas`):
    the products are small, and on a busy machine threads only wait on each other.
    """
    with single_threaded_blas():
        return _diagnose(base, seed, mcmc, progress, log, budget, sample_kw)


def _diagnose(base, seed, mcmc, progress, log, budget, sample_kw):
    model0 = base.model
    free = base.meta.free_response or "none"
    th0 = base.theta_ls
    model0.estimate_noise(th0)
    before = locate(model0, th0)
    ids = [b.channel_id for b in model0.blocks]
    sp = model0.spectra
    sig, q = _screens(model0, th0)
    # the reference's own noise first: a noise-model term, not physics; when it
    # is there, every effect is judged against the model that includes it
    sig["reference_noise"], eiv, th_e, cov_e = reference_noise_test(model0, th0, BIC_KEEP)
    if eiv is not None:
        model0, th0 = eiv, th_e
    # when a drift is a candidate, every model of the search is scored on the
    # per-time-block likelihood (candidates ranked on the same data)
    start = with_effects(model0, [], per_block=drift_candidate(model0, sig["clock_drift"]))
    if start.per_block:
        start.estimate_noise(th0)
    model, th, cov, steps = search(start, th0, free, log=log, drift=sig["clock_drift"],
                                   budget=budget,
                                   eiv=model0 if start.per_block and isinstance(model0, EIVModel) else None)
    stop = steps[-1][-1] if steps and steps[-1] else {}
    incomplete = stop if stop.get("stopped") else None
    tried = sorted({t["effect"] for step in steps for t in step if "effect" in t})
    dropped = []
    if model.effects and incomplete is None:
        model, th, cov, dropped = _prune(model, th, cov, start, th0, sig, log)
    model, th, final, after, before_common = _final_fit(
        base, model, th, cov, (model0, th0, eiv, cov_e), sig=sig, dropped=dropped, free=free,
        seed=seed, mcmc=mcmc, progress=progress, log=log, budget=budget, sample_kw=sample_kw)
    effects = _model_effects(model, final, steps, sig, th)
    effects += orientation_effects(base, model0, th0, ids, sig)
    effects += _tilt_effect(base, sp, ids, sig)
    return Diagnosis(base=base, final=final, before=before, after=after, effects=effects,
                     incomplete=incomplete, tried=tried, dropped=dropped,
                     before_common=before_common,
                     steps=steps, signatures=sig, band_edges=sp.band_edges, ids=ids,
                     ratio_before=q, ratio_after=band_ratio(model, th))


def _screens(model0, th0):
    """The screens of the base fit: ``(sig, q)``, the response-side
    candidates' and a clock drift's signatures, and the per-band ratio
    recorded/predicted."""
    sp = model0.spectra
    q = band_ratio(model0, th0)
    sig = catalogue.signatures(sp.band_centres, q, ratio_weights(sp))
    times, tau_k, w_k = segment_timing(model0, th0)
    sig["clock_drift"] = catalogue.drift_signature(times, tau_k, w_k)
    blocks = block_timing(model0, th0)
    if blocks is not None:
        # a drift large enough to wrap the segments' phases shows in the blocks' lags
        by_block = catalogue.drift_signature(*blocks)
        if abs(by_block["t_stat"]) > abs(sig["clock_drift"]["t_stat"]):
            sig["clock_drift"] = dict(by_block, screen="time blocks' lags")
    return sig, q


def _prune(model, th, cov, start, th0, sig, log):
    """The search's model less the effects the overdispersion does not
    support and a timing offset that differs between the band's halves:
    ``(model, th, cov, dropped)`` (the search's ``start`` when none is left,
    ``cov`` None then)."""
    model, th2, dropped, sig["overdispersion"] = prune_overdispersed(model, th, log=log)
    if any(e.name == "timing_offset" for e in model.effects):
        sig["timing_consistency"] = tc = timing_consistency(model, th2)
        if not tc["consistent"]:
            if log:
                log("  timing_offset dropped: not consistent across sub-bands")
            m, t = without_effects(model, th2, {"timing_offset"})
            m.adopt_noise(model.noise)
            model, th2 = m, best_refit(m, (t,))[1]
            dropped.append({"effect": "timing_offset", "reason": "its size differs between "
                            "the lower and the upper half of the band"})
    if dropped:
        if model.effects:
            th, cov = least_squares_fit(model, th2)
        else:
            model, th, cov = start, th0, None
    return model, th, cov, dropped


def _final_fit(base, model, th, cov, origin, *, sig, dropped, free, seed, mcmc, progress, log,
               budget, sample_kw):
    """Sample the final model, dropping the weakest effect while one's
    posterior does not exclude its absence: ``(model, th, final, after,
    before_common)``. ``origin``: ``(model0, th0, eiv, cov_e)``, the model
    the search started from (the errors-in-variables model when the
    reference's noise is modelled), its point and that model's covariance."""
    model0, th0, eiv, cov_e = origin
    while True:
        if cov is None:
            model, th = model0, th0
            cov = cov_e if eiv is not None else least_squares_fit(model0, th0)[1]
        after = locate(model, th)
        # the base model's misfit under the final noise model: the base's own
        # noise estimate is inflated by the misfit it leaves (before/after on one scale)
        common = with_effects(model0, [], per_block=model.per_block)
        common.adopt_noise(model.noise)
        before_common = locate(common, best_refit(common, (th0,))[1])
        if mcmc and budget is not None and (model.effects or eiv is not None):
            mcmc = _chain_affordable(model, budget, sample_kw)
        if not (model.effects or eiv is not None):
            final = base    # nothing to add to the response model: the final fit is the base fit
            break
        final = _improved_posterior(base, model, th, cov, eiv=eiv, th0=th0, sig=sig, free=free,
                                    seed=seed, mcmc=mcmc, progress=progress, sample_kw=sample_kw)
        weak = weak_effects(model, final.samples) or misfit_not_lowered(before_common, after,
                                                                             model)
        if not weak:
            break
        model, th, cov = _drop_weakest(model, th, weak, dropped, log, (model0, th0))
    return model, th, final, after, before_common


def misfit_not_lowered(before, after, model):
    """The last effect of ``model`` (the weakest the search kept) in
    :func:`.naming.weak_effects`'s form when modelling leaves the largest
    standardised misfit no lower: ``before`` and ``after`` are
    :func:`.locate.locate` of the model without its effects and of
    ``model``, both under ``model``'s noise model (one noise estimate for
    both: a model's own estimate takes in part of the misfit it leaves, so
    that two models' own checks do not compare), compared by their mean
    over bands and channels (an effect that removes its own misfit lowers
    it, whatever a mismatch elsewhere does). An effect whose modelling does
    not lower the misfit is not named. Empty when it is lower, or
    ``model`` has no effect."""
    b, a = (float(np.mean(x["misfit"])) for x in (before, after))
    if not model.effects or a < b:
        return []
    return [(0.0, effect_key(model.effects[-1]), 0.0, model.effects[-1].n_params,
             f"modelling it does not lower the misfit (mean standardised misfit over the "
             f"bands and channels {b:.3g} -> {a:.3g}, both under the improved model's noise "
             "estimate)")]


def _chain_affordable(model, budget, sample_kw):
    """Whether the improved model's chain runs: it gets what is left of the
    budget (at least MIN_CHAIN_WORK), its ``max_steps`` in ``sample_kw``
    cut to it; too few steps, or the time limit (the safety net) passed, and
    the Gaussian approximation stands in for it."""
    n_steps = affordable_steps(model, max(budget.remaining, MIN_CHAIN_WORK))
    if n_steps < MIN_CHAIN_STEPS or budget.out_of_time():
        return False
    sample_kw["max_steps"] = min(int(sample_kw.get("max_steps") or n_steps), n_steps)
    return True


def _improved_posterior(base, model, th, cov, *, eiv, th0, sig, free, seed, mcmc, progress,
                        sample_kw):
    """The improved model's posterior, sampled with the fit's likelihood;
    its Laplace approximation when a chain stops before converging."""
    # sampled with the fit's likelihood: each band's noise scale
    # marginalised as in the fit (core.model.misfit_scale), so that intervals
    # widen where the improved model still misfits (the search compares
    # the Gaussian likelihoods)
    model.misfit_shape = getattr(base.model, "misfit_shape", np.inf)
    meta = base.meta.to_dict() if eiv is None else dict(
        base.meta.to_dict(), reference_noise=dict(reference_noise_meta(eiv, th0),
                                        chosen_by="diagnose",
                                        reason=sig["reference_noise"]["explanation"]))
    if free == "all" and all(b.free != "all" for b in model.blocks):
        # the corner under its wide prior took the place of the fitted
        # pendulums (search.released): the blocks hold them at the metadata's
        # values, the corner effect carries what the data say of them
        free = "gain"
        meta = dict(meta, free_response="gain")
    final = posterior_of(model, th, cov, meta, base.not_estimable, free, seed=seed,
                         mcmc=mcmc, progress=progress, **sample_kw)
    if mcmc and not final.convergence.converged:
        # a chain stopped before converging (a start at a bound, a ridge):
        # the Gaussian approximation at the least-squares point instead
        final = posterior_of(model, th, cov, dict(meta, mcmc_not_converged=True),
                             base.not_estimable, free, seed=seed, mcmc=False)
    return final


def _drop_weakest(model, th, weak, dropped, log, start):
    """The model without its weakest effect (whose absence its posterior
    does not exclude; recorded in ``dropped``), re-fitted: ``(model, th,
    cov)``, ``cov`` None when no effect is left. An effect that took up
    the pendulum of channels the fit fitted (``releases``) gives it back
    to them, at the search's ``start`` ``(model, theta)``."""
    _, key, _, _, why = min(weak)
    if log:
        log(f"  {key} dropped: {why}")
    dropped.append({"effect": key, "reason": why})
    gone = next(e for e in model.effects if effect_key(e) == key)
    m, t = without_effects(model, th, {key})
    if not m.effects:
        return model, th, None
    if getattr(gone, "releases", False):
        m, t = restored(m, t, *start)
    m.adopt_noise(model.noise)
    th, cov = least_squares_fit(m, t)
    return m, th, cov


def _model_effects(model, final, steps, sig, th):
    """The entries of the final model's effects, each with its BIC gain
    in the search, its signature and what the recordings cannot tell it
    from (:func:`.search.indistinguishable`, at the final point ``th``)."""
    kept = {s["kept"]: s["delta_bic"] for step in steps for s in step if "kept" in s}
    effects = []
    for k, (e, sl) in enumerate(zip(model.effects, model.effect_slices)):
        entry = _effect_entry(model, e, sl, final.samples, kept.get(effect_key(e)))
        entry["signature"] = sig.get(effect_key(e), {})
        apart = indistinguishable(model, th, k)
        if apart.get("indistinguishable_from"):
            entry.update(apart)
        if apart.get("indistinguishable_from") and "cannot tell" not in entry["explanation"]:
            entry["explanation"] += ("; the recordings cannot tell it from "
                                     + " or ".join(apart["indistinguishable_from"]))
        effects.append(entry)
    return effects


def _tilt_effect(base, sp, ids, sig):
    """The tilt-noise test on the horizontals by their metadata
    (:func:`.tilt.tilt_test`, into ``sig``): its entry when it names
    channels, in a list (empty otherwise)."""
    nominal = _nominal_vectors(base.meta, ids) if base.meta.nominal else None
    if nominal is None:
        return []
    horizontal = np.abs(np.degrees(np.arcsin(np.clip(nominal[:, 2], -1, 1)))) < 45
    t = tilt.tilt_test(sp, horizontal, bic_keep=BIC_KEEP)
    sig["tilt_noise"] = t     # with the noise-spectrum misfit before/after (misfit_base/_tilt)
    if not (t["applicable"] and t["kept"] and t["channels"]):
        return []
    before, after = t["misfit_largest"]["base"], t["misfit_largest"]["tilt"]
    if after >= before:       # its modelling does not lower the noise spectra's misfit
        t["dropped"] = (f"modelling it does not lower the noise spectra's largest "
                        f"standardised misfit ({before:.3g} -> {after:.3g})")
        return []
    params = {"alpha": t["alpha"]}
    for i in t["channels"]:
        params[f"noise_to_signal_lowest_band:{ids[i]}"] = \
            t["per_channel"][str(i)]["nsr_lowest_band"]
    return [{"name": "tilt_noise", "channels": [ids[i] for i in t["channels"]],
             "parameters": params, "score_gain": t["delta_bic"],
             "misfit": {"before": before, "after": after,
                        "of": "the noise-to-signal model of the SUT's channels"},
             "explanation": t["explanation"] + f" (the noise spectra's largest standardised "
             f"misfit {before:.3g} -> {after:.3g}); it is noise, not a response "
             "error: the per-band noise model carries it (those bands weigh "
             "less), so the orientation and response estimates do not move",
             "signature": sig["tilt_noise"]}]
