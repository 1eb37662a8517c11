"""Which effects to add: catalogue candidates for the current model, their fits
(grid start, then least squares), and their BIC scores under one noise
model (see :mod:`.diagnose`).
"""
from __future__ import annotations

from dataclasses import replace

import numpy as np

from . import effects as catalogue, words
from ..core.model import forward_jacobian, EIVModel, EIVNoise, MIN_TIME_BLOCKS, Model
from ..core.fit import TIGHT, solve, prior_bounds
from ..core.threads import single_threaded_blas
from ..core.orientation import Fixed
from ..core.response import TwoPoleFamily
from .per_block import drift_under_eiv, search_again, set_aside, stopped
from .starts import best_start_fit, grid_starts
from .prior_choice import BY_EVIDENCE, by_evidence, log_evidence_gain, prior_conflict


#: An effect is kept when it improves the BIC by more than this ("very
#: strong" evidence on the Kass & Raftery scale).
BIC_KEEP = 10.0
MAX_EFFECTS = 3
#: Least-squares starts (best grid maxima) for effects with a multimodal likelihood.
N_STARTS = 3
#: |t| of the per-segment timing trend above which clock drift is a candidate
#: (a cheap screen; the BIC decides).
DRIFT_T = 3.0


#: The SUT's pendulum under the sensor's stated prior or under a wide one:
#: one of them at most in a model (each replaces the metadata's pendulum).
PENDULUM_ALTERNATIVES = ("response_parameters", "sut_corner")


def _candidates(model, free, current, drift=None):
    """(key, effect, grid of starting parameters) for every applicable
    catalogue entry not already in ``current`` (list of effects)."""
    sp = model.spectra
    rows = list(range(sp.n_u))
    fmin, fmax = float(sp.band_edges[0]), float(sp.band_edges[-1])
    have = {effect_key(e) for e in current}
    out = []
    span = min(5.0, 0.5 / fmin)
    step = 0.05 / fmax
    if not any(e.name == "clock_drift" for e in current):
        out.append(("timing_offset", catalogue.TimingOffset(rows),
                    np.arange(-span, span + step, step)[:, None]))
    if drift_candidate(model, drift):
        taus = np.arange(-span, span + step, step)
        out.append(("clock_drift", catalogue.ClockDrift(rows, sp),
                    np.column_stack([taus, np.full(taus.size, drift["ppm"])])))
    norm = model.blocks[0].family.norm_freq if model.blocks[0].family is not None else 1.0
    x = np.r_[np.geomspace(0.03 / fmax, 3.0 / fmin, 60)]
    for which in ("sut", "ref"):
        n = sum(1 for e in current if e.name == "extra_pole" and e.which == which)
        e = catalogue.ExtraPole(rows, which, norm)
        e.index = n + 1
        if n:   # unique parameter names for a second pole on the same sensor
            e.param_names = (f"inverse_corner_s_{n + 1}",)
        out.append((effect_key(e), e, x[:, None]))
    pendulum = [i for i, b in enumerate(model.blocks)
                if b.free != "all" and isinstance(b.family, TwoPoleFamily)]
    if pendulum:
        fams = [model.blocks[i].family for i in pendulum]
        steps = [(a, b) for a in (-0.1, 0.0, 0.1) for b in (-0.05, 0.0, 0.05)]
        e = catalogue.ResponseParameters(pendulum, fams,
                                         [model.blocks[i].channel_id for i in pendulum],
                                         model.priors)
        out.append(("response_parameters", e, e.grid(steps)))
    held = [i for i, b in enumerate(model.blocks) if b.free != "all" and b.family is not None]
    fitted = [i for i, b in enumerate(model.blocks)
              if b.free == "all" and isinstance(b.family, TwoPoleFamily)]
    if held or fitted:
        rows = held or fitted
        e = catalogue.SutCorner(rows, [model.blocks[i].family for i in rows],
                                [model.blocks[i].channel_id for i in rows], fmin)
        #: in place of blocks that fit the pendulum under the stated prior
        e.releases = not held
        out.append(("sut_corner", e, e.grid()))
    if free == "none":
        for i, b in enumerate(model.blocks):
            out.append((f"gain_error:{i}", catalogue.GainError(i, b.channel_id),
                        np.linspace(-0.6, 0.6, 61)[:, None]))
    if have & set(PENDULUM_ALTERNATIVES):
        # one pendulum per channel: the stated prior's or the wide corner's
        have |= set(PENDULUM_ALTERNATIVES)
    return [c for c in out if c[0] not in have]


def _fitted_offset(model, theta, tried):
    """The timing offset (s) of the current model or of this step's timing
    candidate, or None: the start of a clock drift's fit (its offset at
    mid-record is the constant offset's, to first order)."""
    for e, sl in zip(model.effects, model.effect_slices):
        if e.name == "timing_offset":
            return float(np.asarray(theta)[sl][0])
    for t in tried:
        if t["effect"] == "timing_offset" and t.get("fit") is not None:
            m, th, _ = t["fit"]
            return _fitted_offset(m, th, [])
    return None


def drift_candidate(model, drift):
    """Whether a clock drift is tried: the per-segment timing trend passes
    the screen and the spectra have enough time blocks."""
    bt = model.spectra.block_totals
    return (drift is not None and abs(drift["t_stat"]) > DRIFT_T and bt is not None
            and bt.shape[0] >= MIN_TIME_BLOCKS)


def effect_key(effect):
    if effect.name == "extra_pole":
        k = getattr(effect, "index", 1)
        return f"extra_pole:{effect.which}" + (f"#{k}" if k > 1 else "")
    if effect.name == "gain_error":
        return f"gain_error:{effect.rows[0]}"
    return effect.name


def with_effects(model, effects, per_block=False, blocks=None):
    """``model`` with ``effects`` (and channel ``blocks``, its own by
    default) and its noise model. Once a time-dependent effect is in, the
    likelihood is per time block (and stays so, so that the models a search
    compares use the same data)."""
    per_block = per_block or model.per_block or any(e.blocked for e in effects)
    blocks = model.blocks if blocks is None else blocks
    if isinstance(model, EIVModel) and not per_block:
        m = EIVModel(model.spectra, model.ref_vectors, blocks, model.priors,
                     ref_noise=model.ref_noise, effects=effects,
                     known_noise=getattr(model, "known_noise", None))
    else:   # the per-block likelihood exists for the base model only
        m = Model(model.spectra, model.ref_vectors, blocks, model.priors, effects=effects,
                  per_block=per_block)
        m.inflation_floor = model.inflation_floor
        if isinstance(model.noise, EIVNoise):   # no common noise model: estimated by the caller
            return m
    m.inflation_floor = model.inflation_floor      # the record's floor (record.pooling)
    if model.noise is not None:
        m.adopt_noise(model.noise)
    return m


def released(model, theta, rows):
    """``model`` with its channel blocks ``rows`` holding their pendulum
    (gain only: a :class:`.effects.SutCorner` on them takes it up) and
    ``theta`` carried over (orientation, log gain and effects kept).
    Returns (model, theta)."""
    theta = np.asarray(theta, float)
    blocks = [replace(b, free="gain") if i in rows else b for i, b in enumerate(model.blocks)]
    pieces = []
    for i, (so, sr) in enumerate(model.slices):
        pieces += [theta[so], theta[sr][-1:] if i in rows else theta[sr]]
    m = with_effects(model, model.effects, blocks=blocks)
    return m, np.concatenate(pieces + [theta[sl] for sl in model.effect_slices])


def restored(model, theta, base, base_theta):
    """The inverse of :func:`released`: ``model`` with ``base``'s channel
    blocks back, each block ``model`` holds at gain only where ``base`` fits
    its pendulum taking its response parameters from ``base_theta`` (the
    search's start) and keeping ``theta``'s orientation, log gain and
    effects. Returns (model, theta)."""
    theta, bt = np.asarray(theta, float), np.asarray(base_theta, float)
    pieces = []
    for (so, sr), (_, bsr), b, bb in zip(model.slices, base.slices, model.blocks, base.blocks):
        pieces += [theta[so]] + ([bt[bsr][:-1], theta[sr][-1:]] if b.free != bb.free
                                 else [theta[sr]])
    m = with_effects(model, model.effects, blocks=base.blocks)
    return m, np.concatenate(pieces + [theta[sl] for sl in model.effect_slices])


def theta_base(model, theta):
    """The channel-block part of ``theta`` (effects stripped)."""
    n = sum(b.n_params for b in model.blocks)
    return np.asarray(theta)[:n]


def _effect_params(model, theta):
    return {effect_key(e): np.asarray(theta)[sl]
            for e, sl in zip(model.effects, model.effect_slices)}


def fit_candidate(cur_model, cur_theta, effects, grid, new_index):
    """Least-squares fit of ``cur_model`` extended by ``effects`` (the new
    effect at ``new_index`` starts at the best point of ``grid`` under the
    current noise model). Returns (model, theta, cov) or None when the fit
    leaves the effect's prior support."""
    m = with_effects(cur_model, effects)
    old = _effect_params(cur_model, cur_theta)
    base = list(theta_base(cur_model, cur_theta))
    pieces, new_slice, i = [], None, len(base)
    for k, e in enumerate(effects):
        if k == new_index:
            pieces.append(np.zeros(e.n_params))
            new_slice = slice(i, i + e.n_params)
        else:
            pieces.append(old.get(effect_key(e), np.zeros(e.n_params)))
        i += e.n_params
    theta0 = np.concatenate([base] + pieces)
    trial = np.repeat(theta0[None], len(grid), axis=0)
    trial[:, new_slice] = grid
    lp = m.log_prior(trial)
    ok = np.isfinite(lp)
    ll = np.full(len(grid), -np.inf)
    ll[ok] = m.log_likelihood(trial[ok])
    new = effects[new_index]
    starts = grid_starts(trial, ll, N_STARTS if getattr(new, "multimodal", False) else 1)
    best = best_start_fit(m, starts, cur_model.noise)
    if best is None:
        return None
    theta, cov, m.noise = best
    sp = m.spectra
    if hasattr(new, "identifiable") and not new.identifiable(theta[new_slice], sp.band_edges[0],
                                                             sp.band_edges[-1]):
        return None
    return m, theta, cov


def _best_loglik(model, starts):
    """Largest log-likelihood of ``model`` under its (fixed) noise model,
    maximised by least squares from each of ``starts``."""
    return best_refit(model, starts)[0]


def best_refit(model, starts):
    """(log-likelihood, theta) of the best least-squares refit of ``model``
    from ``starts`` under its fixed noise model."""
    if model.ndim == 0:
        return float(model.log_likelihood(np.zeros((1, 0)))[0]), np.zeros(0)
    fac = model.noise.cholesky()
    lo, hi = prior_bounds(model)
    bounded = bool(np.isfinite(lo).any())
    best = (-np.inf, None)
    for start in starts:
        res = solve(model.whitened_residual, np.clip(start, lo + 1e-9, hi - 1e-9),
                    *((lo, hi) if bounded else ()), method="trf" if bounded else "lm",
                    jac=forward_jacobian(model, matmul=True), args=(fac,), **TIGHT)
        ll = float(model.log_likelihood(res.x)[0])
        if ll > best[0]:
            best = (ll, res.x)
    return best


def held_orientation_loglik(model, theta, axes):
    """Log-likelihood with every SUT axis held at ``axes`` (n_u, 3) and the
    response parameters re-fitted, under ``model``'s noise model."""
    blocks = [replace(b, manifold=Fixed(np.asarray(a, float))) for b, a in zip(model.blocks, axes)]
    if isinstance(model, EIVModel):
        held = EIVModel(model.spectra, model.ref_vectors, blocks, model.priors,
                        ref_noise=model.ref_noise)
    else:
        held = Model(model.spectra, model.ref_vectors, blocks, model.priors)
    held.inflation_floor = model.inflation_floor
    held.adopt_noise(model.noise)
    start = np.concatenate([np.asarray(theta)[sr] for _, sr in model.slices])
    return _best_loglik(held, (start,))


def orientation_score(model, theta, nominal, finding):
    """BIC difference between the metadata's axes and the metadata's axes
    with ``finding``'s channels reversed or exchanged, both held fixed (no
    extra parameter: ``2 (logL_alt - logL_metadata)``) under the base
    model's noise model."""
    alt = np.array(nominal, float)
    rows = finding["rows"]
    if "axis" in finding:           # exchanged with a channel the fit could not use
        alt[rows[0]] = finding["axis"]
    elif finding["name"] == "channel_swap":
        alt[rows] = nominal[rows[::-1]]
    else:
        alt[rows] = -nominal[rows]
    return 2.0 * (held_orientation_loglik(model, theta, alt)
                  - held_orientation_loglik(model, theta, nominal))


def score(cur_model, cur_theta, ext_model, ext_theta):
    """BIC gain of ``ext_model`` over ``cur_model`` under the extended
    model's noise model (the current model re-optimised under it)."""
    cur = with_effects(cur_model, cur_model.effects, per_block=ext_model.per_block)
    cur.adopt_noise(ext_model.noise)
    # start from the current optimum and from the extended optimum's shared
    # parameters (the plug-in noise moves the optimum), keep the better
    if [b.free for b in ext_model.blocks] != [b.free for b in cur.blocks]:
        # in place of blocks fitted under the stated prior (:func:`released`):
        # the current model at its own point, under that prior (re-optimised
        # without it, as least squares here does, it would reach the
        # extended model's optimum)
        ll_cur = float(cur.log_likelihood(np.asarray(cur_theta, float)[None])[0])
    else:
        ext_params = _effect_params(ext_model, ext_theta)
        shared = np.concatenate([theta_base(ext_model, ext_theta)] + [
            ext_params.get(effect_key(e), np.asarray(cur_theta)[sl])
            for e, sl in zip(cur.effects, cur.effect_slices)])
        ll_cur = _best_loglik(cur, (np.asarray(cur_theta, float), shared))
    ll_ext = float(ext_model.log_likelihood(ext_theta)[0])
    # one sample size for every comparison: the band-summed residual's
    # entries (time blocks split the same data, they add none)
    sp = cur_model.spectra
    n = 2 * sp.n_bands * sp.n_u * sp.n_r
    k = ext_model.ndim - cur_model.ndim
    return {"delta_loglik": ll_ext - ll_cur, "delta_bic": 2 * (ll_ext - ll_cur) - k * np.log(n),
            "n_data": n, "n_extra_params": k}


#: What a pair of recordings can never tell a named effect from (its
#: response relative to the reference's metadata is the same).
NEVER_APART = {
    "extra_pole:sut": "a zero missing from the reference's metadata",
    "extra_pole:ref": "a zero missing from the SUT's metadata",
    "sut_corner": "the reference's long-period corner off its metadata",
}


def indistinguishable(model, theta, index):
    """What the recordings cannot tell effect ``index`` of ``model`` (at
    ``theta``, its noise model set) from: ``{"indistinguishable_from":
    [...], "evidence": ...}``, or ``{}``. A missing pole on one sensor is
    a zero missing on the other, and the SUT's corner the reference's
    (:data:`NEVER_APART`: a pair never can). A timing offset ``tau`` is
    compared with the minimum-phase pole whose phase starts as the delay's
    (``1 / corner = 2 pi |tau|``: a pole on the SUT for a late clock, on the
    reference for an early one), re-fitted in its place: when the BIC of
    the two differs by no more than :data:`BIC_KEEP`, the evidence does not
    separate them."""
    e = model.effects[index]
    key = effect_key(e)
    if key.split("#")[0] in NEVER_APART:
        return {"indistinguishable_from": [NEVER_APART[key.split("#")[0]]],
                "evidence": "a pair of recordings never separates them"}
    if e.name != "timing_offset":
        return {}
    tau = float(np.asarray(theta)[model.effect_slices[index]][0])
    which = "sut" if tau > 0 else "ref"
    norm = model.blocks[0].family.norm_freq if model.blocks[0].family is not None else 1.0
    pole = catalogue.ExtraPole(e.rows, which, norm)
    pole.index = 1 + sum(1 for x in model.effects if x.name == "extra_pole" and x.which == which)
    if pole.index > 1:
        pole.param_names = (f"inverse_corner_s_{pole.index}",)
    effects = [x if k != index else pole for k, x in enumerate(model.effects)]
    alt = with_effects(model, effects)
    alt.adopt_noise(model.noise)
    start = np.array(theta, float)
    start[model.effect_slices[index]] = 2 * np.pi * abs(tau)
    ll_alt, th_alt = best_refit(alt, (start,))
    if th_alt is None or not np.isfinite(alt.log_prior(th_alt)[0]):
        return {}
    d_bic = 2.0 * (float(model.log_likelihood(np.asarray(theta, float))[0]) - ll_alt)
    where = "SUT" if which == "sut" else "reference"
    if d_bic > BIC_KEEP:
        return {"evidence": f"the delay is preferred over a pole on the {where} "
                            f"(BIC {d_bic:.3g})"}
    corner = 1.0 / max(float(th_alt[model.effect_slices[index]][0]), 1e-12)
    return {"indistinguishable_from": [
        f"a pole near {corner:.3g} Hz on the {'SUT' if which == 'sut' else 'reference'} "
        "(a minimum-phase response, not a clock)"],
        "evidence": f"BIC difference {d_bic:.3g}, within {BIC_KEEP:g}"}


def search(model, theta, free, log=None, drift=None, budget=None, eiv=None):
    """Greedy search: add the best-scoring catalogue effect while its BIC
    gain exceeds :data:`BIC_KEEP`. Returns (model, theta, cov, steps).
    ``budget`` (a :class:`bayescal.core.budget.Budget`): checked before each
    candidate; once spent the search stops and its last step holds
    ``{"stopped": "budget"}`` (or ``"time limit"`` when the budget's safety
    net ended it; the candidates not tried are listed there).
    ``eiv``: the errors-in-variables base model, when ``model`` is the
    per-block base model a clock drift needs; once a drift is named the
    search goes on under ``eiv`` on the spectra with the drift taken out
    (:func:`.per_block.drift_under_eiv`); when none is named, the search
    runs again under ``eiv`` (:func:`.per_block.search_again`), or, where
    the budget stopped it, keeps none of the per-block search's effects.
    BLAS runs single-threaded (small products: threads only add latency)."""
    with single_threaded_blas():
        out = _search(model, theta, free, log, drift, budget, eiv)
        if not search_again(out, eiv, log):
            return out
        base, theta = with_effects(eiv, []), np.asarray(theta, float)
        if stopped(out[3]):         # no budget left to score them again: none is kept
            return base, theta, None, set_aside(out[3])
        cur, th, cov, more = _search(base, theta, free, log, None, budget, None)
        return cur, th, cov, set_aside(out[3]) + more


def _search(model, theta, free, log, drift, budget=None, eiv=None):
    cur, th, cov = model, theta, None
    steps = []
    while len(cur.effects) < MAX_EFFECTS:
        if log:
            log(words.round_header(len(steps) + 1, [e.name for e in cur.effects], BIC_KEEP))
        tried, stop = _round(cur, th, free, drift, budget, log)
        if stop is not None:
            steps.append([{k: v for k, v in t.items() if k != "fit"} for t in tried] + [stop])
            if log:
                log(f"round {len(steps)} stopped: the criticism's {stop['stopped']} is spent "
                    f"(not tried: {', '.join(stop['not_tried'])})")
            return cur, th, cov, steps
        best = _best(tried, log)
        steps.append([{k: v for k, v in t.items() if k != "fit"} for t in tried])
        if log:
            log(words.round_outcome(len(steps), best, tried, BIC_KEEP,
                                    MAX_EFFECTS if len(cur.effects) + 1 >= MAX_EFFECTS else None))
        if best is None or best["delta_bic"] <= BIC_KEEP:
            break
        cur, th, cov = best["fit"]
        steps[-1].append({"kept": best["effect"], "delta_bic": best["delta_bic"]})
        if best["effect"] == "clock_drift" and eiv is not None:
            steps[:-1] = set_aside(steps[:-1])
            base = theta_base(*restored(cur, th, model, theta))
            cur, th, cov = drift_under_eiv(eiv, cur, th, cov, log, base=base)
    return cur, th, cov, steps


def _round(cur, th, free, drift, budget, log):
    """One round of the search: every candidate effect fitted and scored
    against ``cur``. Returns ``(tried, stop)``: the entries of the
    candidates tried (with their fits), and None or the entry saying the
    budget ended the round."""
    tried = []
    cands = _candidates(cur, free, cur.effects, drift)
    for n, (key, effect, grid) in enumerate(cands):
        if budget is not None and budget.spent():
            why = "time limit" if budget.ended_by == "time" else "budget"
            return tried, {"stopped": why, "not_tried": [c[0] for c in cands[n:]]}
        effects = list(cur.effects)
        if key == "clock_drift":      # nests timing_offset: replaces it
            effects = [e for e in effects if e.name != "timing_offset"]
            tau = _fitted_offset(cur, th, tried)
            if tau is not None:       # start at the offset found (no grid over it)
                grid = np.array([[tau, grid[0, 1]]])
        effects.append(effect)
        on = released(cur, th, effect.rows) if getattr(effect, "releases", False) else (cur, th)
        fit = fit_candidate(*on, effects, grid, len(effects) - 1)
        if fit is None:
            tried.append({"effect": key, "delta_bic": None,
                          "note": "left the prior support or not identifiable in the band"})
            if log:
                log(f"  {key:20s} not scored: {tried[-1]['note']}")
            continue
        s = score(cur, th, fit[0], fit[1])
        if key in BY_EVIDENCE:
            s["log_evidence_gain"] = log_evidence_gain(fit, s, len(effects) - 1)
        if key == "sut_corner":
            s.update(prior_conflict(cur.priors, fit, len(effects) - 1))
        tried.append({"effect": key, **s, "fit": fit,
                      **({"first": True} if getattr(effect, "first", False) else {}),
                      **({"releases": True} if getattr(effect, "releases", False) else {})})
        if log:
            log(f"  {key:20s} BIC gain {s['delta_bic']:10.1f}")
    return tried, None


def _best(tried, log):
    """The candidate a round keeps (its BIC gain still to be checked against
    :data:`BIC_KEEP`), or None. An effect marked ``first`` (the SUT's corner
    on metadata that give none: a term of the response family the base model
    lacks) comes before the others whenever it passes; a delay and poles
    near the band's top, which trade with each other there, would otherwise
    fill the steps first."""
    good = by_evidence([t for t in tried if t.get("delta_bic") is not None], BIC_KEEP)
    best = max(good, key=lambda t: (t.get("first", False) and t["delta_bic"] > BIC_KEEP,
                                    t["delta_bic"]), default=None)
    timing = next((t for t in good if t["effect"] == "timing_offset"), None)
    if best is not None and best["effect"] == "clock_drift" and timing is not None \
            and best["delta_bic"] > BIC_KEEP:
        # clock drift nests a constant offset: it must beat it, not only the current model
        s = score(timing["fit"][0], timing["fit"][1], best["fit"][0], best["fit"][1])
        if log:
            log(f"  clock_drift over timing_offset BIC gain {s['delta_bic']:10.1f}")
        if s["delta_bic"] <= BIC_KEEP and timing["delta_bic"] > BIC_KEEP:
            best = timing
    return best
