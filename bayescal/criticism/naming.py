"""Which of the effects a search kept are named: backward elimination
(:func:`prune`, scaled by the misfit the final model leaves,
:func:`prune_overdispersed`), a timing offset's consistency across the band
(:func:`timing_consistency`) and the posterior's exclusion of each effect's
absence (:func:`weak_effects`). See docs/diagnose.md, "Naming only what is
there"."""
from __future__ import annotations

import numpy as np

from .locate import band_ratio, overdispersion, ratio_weights
from .search import BIC_KEEP, effect_key, best_refit, theta_base, with_effects, score


def without_effects(model, theta, drop):
    """(model, theta) with the effects whose keys are in ``drop`` removed
    (the channel blocks' and the other effects' parameters kept)."""
    keep = [(e, sl) for e, sl in zip(model.effects, model.effect_slices) if effect_key(e) not in drop]
    m = with_effects(model, [e for e, _ in keep])
    th = np.concatenate([theta_base(model, theta)] + [np.asarray(theta)[sl] for _, sl in keep])
    return m, th


def prune(model, theta, log=None, keep=BIC_KEEP, min_effects=1):
    """Backward elimination: drop a kept effect whose removal (the rest
    re-fitted under the final noise model) costs no more than ``keep``; one
    at a time, the weakest first. One cause absorbed by two entries (a delay
    and a pole far above the band, say) leaves one. Returns (model, theta,
    dropped keys with their BIC gain)."""
    dropped = []
    while len(model.effects) > min_effects - 1 and model.effects:
        gains = []
        for e in model.effects:
            if not getattr(e, "prunable", True):
                continue
            m, th = without_effects(model, theta, {effect_key(e)})
            gains.append((score(m, th, model, theta)["delta_bic"], effect_key(e)))
        if not gains:
            break
        gain, key = min(gains)
        if gain > keep:
            break
        if log:
            log(f"  {key} dropped: BIC gain {gain:.1f} for keeping it, {keep:.1f} needed")
        m, th = without_effects(model, theta, {key})
        m.adopt_noise(model.noise)
        model, theta = m, best_refit(m, (th,))[1]
        dropped.append({"effect": key, "delta_bic": float(gain), "needed": float(keep)})
    return model, theta, dropped


#: An effect is named only when its posterior (the fit's likelihood, the
#: improved model) puts its null value (no effect) outside this central
#: region: at most 1 - NAME_LEVEL of absent effects named per candidate
#: kept by the search, when the posterior is calibrated.
NAME_LEVEL = 0.99


def weak_effects(model, samples, level=NAME_LEVEL):
    """The effects of ``model`` whose absence the posterior ``samples``
    (model coordinates) does not exclude: the squared Mahalanobis distance
    of the effect's null value (``effect.null``, 0 by default) from the
    posterior mean of its parameters (those in ``effect.absence``, all by
    default), against the ``level`` quantile of a
    chi-square with one degree of freedom per parameter (a clock drift
    carried to the errors-in-variables model: its rate over its standard
    deviation). An effect with an identifiability rule (a missing pole: its
    corner below three times the band's top) must meet it at the posterior's
    ``1 - level`` quantile too, else it counts as not excluded (distance 0).
    Returns [(distance^2 / quantile, key, distance^2, dof, reason)]."""
    from scipy.stats import chi2

    out = []
    sp = model.spectra
    for e, sl in zip(model.effects, model.effect_slices):
        if hasattr(e, "identifiable"):
            low = np.quantile(samples[:, sl], 1.0 - level, axis=0)
            if not e.identifiable(low, sp.band_edges[0], sp.band_edges[-1]):
                out.append((0.0, effect_key(e), 0.0, e.n_params,
                            f"it is not identifiable in the band at {100 * level:g} %"))
                continue
        if hasattr(e, "ppm_sd"):
            d2, k = (e.ppm / e.ppm_sd) ** 2 if e.ppm_sd > 0 else np.inf, 1
        else:
            x = samples[:, sl] - getattr(e, "null", 0.0)
            x = x[:, list(getattr(e, "absence", range(e.n_params)))]
            mean = x.mean(axis=0)
            cov = np.atleast_2d(np.cov(x.T)) if len(x) > 1 else np.full((1, 1), np.nan)
            k = x.shape[1]
            if not (np.all(np.isfinite(cov)) and np.all(np.isfinite(mean))):
                continue        # no posterior spread to judge by (a single point)
            d2 = float(mean @ np.linalg.pinv(cov) @ mean)
        q = float(chi2.ppf(level, k))
        if d2 < q:
            out.append((d2 / q, effect_key(e), float(d2), int(k),
                        f"its posterior does not exclude its absence at {100 * level:g} % "
                        f"(squared distance {d2:.3g} with {k} parameter(s))"))
    return out


def prune_overdispersed(model, theta, log=None):
    """:func:`prune` with the evidence needed scaled by the overdispersion
    the final model leaves (a quasi-likelihood guard, as for tilt noise): an
    effect that improves a model still missing everywhere by a factor
    ``phi`` must gain more than ``phi`` times :data:`BIC_KEEP`; what the
    noise model cannot describe is not physics to name. First the effects
    the others explain (no scaling), then the overdispersed test, repeated
    while it drops (dropping raises the misfit)."""
    model, theta, dropped = prune(model, theta, log=log, min_effects=2)
    phi = 1.0
    while model.effects:
        phi = overdispersion(model, theta)
        # a drift carried from the per-block model brings the misfit that
        # model left: what its rate's error leaves in the spectra is not
        # physics to name either (the rate's interval is widened by it too)
        carried = max((getattr(e, "dispersion", 1.0) for e in model.effects), default=1.0)
        why = (f"the model still misses by a factor {phi:.2g} everywhere: its gain is within "
               "what that misfit explains")
        if carried > phi and any(getattr(e, "prunable", True) for e in model.effects):
            phi = carried
            why = (f"the clock drift's per-block model misses by a factor {phi:.2g}: its gain "
                   "is within what an error in the drift's rate of that size leaves")
        if phi <= 1.0:
            break
        model, theta, more = prune(model, theta, log=log, keep=BIC_KEEP * phi)
        dropped += [dict(d, reason=why) for d in more]
        if not more:
            break
    return model, theta, dropped, phi


#: Sub-band timing offsets agree when they differ by less than this many
#: standard errors or this fraction of the offset, whichever is larger.
TIMING_AGREE_SD, TIMING_AGREE_FRACTION = 4.0, 0.25
#: A clock offset delays every frequency: each half of the band must show it
#: on its own, at least this many of its standard errors from zero.
TIMING_SEEN_SD = 2.0


def timing_consistency(model, theta):
    """A timing offset in ``model`` read separately from the lower and upper
    half of the bands: the offset plus the phase slope of the
    recorded/predicted ratio that the model with the offset leaves there (a
    residual phase, so no wrapping). ``consistent``: the two agree (same
    sign, within :data:`TIMING_AGREE_SD` standard errors or
    :data:`TIMING_AGREE_FRACTION` of the offset) and each is at least
    :data:`TIMING_SEEN_SD` standard errors from zero (a clock delays every
    frequency; a phase that one half alone shows is a response's). Returns
    a JSON-safe dict."""
    i = next(k for k, e in enumerate(model.effects) if e.name == "timing_offset")
    sl = model.effect_slices[i]
    tau = float(np.asarray(theta)[sl][0])
    q = band_ratio(model, np.asarray(theta, float))
    w = ratio_weights(model.spectra)
    f = model.spectra.band_centres
    phase = np.unwrap(np.angle(q), axis=0)
    half = len(f) // 2
    out = []
    for sel in (slice(0, max(half, 1)), slice(max(half, 1), None)):
        ff, ph, ww = f[sel, None], phase[sel], 2.0 * w[sel]
        if ph.size == 0:
            continue
        den = np.sum(ww * ff * ff)
        t = -np.sum(ww * ff * ph) / (2 * np.pi * den)
        # the phase's scatter about the line sets the error (at least its noise)
        chi = np.sum(ww * (ph + 2 * np.pi * ff * t) ** 2) / max(ph.size - 1, 1)
        sd = np.sqrt(max(chi, 1.0) / den) / (2 * np.pi)
        out.append({"band_hz": [float(model.spectra.band_edges[sel][0]),
                                float(model.spectra.band_edges[1:][sel][-1])],
                    "seconds": float(tau + t), "sd": float(sd)})
    if len(out) < 2:
        return {"seconds": tau, "sub_bands": out, "consistent": True}
    a, b = out
    diff = abs(a["seconds"] - b["seconds"])
    ok = (np.sign(a["seconds"]) == np.sign(b["seconds"])
          and diff <= max(TIMING_AGREE_SD * np.hypot(a["sd"], b["sd"]),
                          TIMING_AGREE_FRACTION * abs(tau))
          and all(abs(x["seconds"]) >= TIMING_SEEN_SD * x["sd"] for x in out))
    return {"seconds": tau, "sub_bands": out, "consistent": bool(ok)}
