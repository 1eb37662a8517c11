"""Model criticism: locate the mismatch between the fitted model and the
recordings, name the physics left out, model it, show the fit improve.

Steps (see docs/diagnose.md):

1. **Locate** (:func:`locate`): per band and SUT channel, the standardised
   misfit ``v`` of the fitted model (whitened residual energy over its
   expectation; ``n_r v ~ Gamma(n_r, 1)`` under the model) and its p-value;
   cells below ``ALPHA / (B n_u)`` (Bonferroni) are a mismatch. Also the
   per-band complex ratio recorded/predicted (:func:`band_ratio`) and
   coherences, which the signatures in :mod:`bayescal.physics` read.
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
   extension of a model of the noise spectra (:mod:`bayescal.tilt`), scored
   by its own BIC.
3. **Show**: misfit per band before and after, score gains, effect
   parameters with credible intervals (MCMC on the final model, or its
   Laplace approximation), and how orientation and response moved.
"""
from __future__ import annotations

from dataclasses import replace

import numpy as np
from scipy.optimize import least_squares
from scipy.stats import gamma

from . import physics, tilt
from .fit import _bounds, diagnostics, least_squares_fit, sample
from .geometry import Fixed, unit_vector
from .likelihood import MIN_TIME_BLOCKS, Model
from .posterior import Posterior, interval_summary

SCHEMA = "bayescal.diagnose/1"
#: Family-wise false-alarm level of the mismatch test (Bonferroni over cells).
ALPHA = 0.01
#: An effect is kept when it improves the BIC by more than this ("very
#: strong" evidence on the Kass & Raftery scale).
BIC_KEEP = 10.0
MAX_EFFECTS = 3
#: Least-squares starts (best grid maxima) for effects with a multimodal likelihood.
N_STARTS = 3
#: |t| of the per-segment timing trend above which clock drift is a candidate
#: (a cheap screen; the BIC decides).
DRIFT_T = 3.0


# --- locate -----------------------------------------------------------------

def band_ratio(model, theta):
    """(B, n_u) complex ratio of what each SUT channel recorded (deconvolved
    by the model's response) over what the model predicts from the
    reference, per band: ``(S_ur t_i) / (t_i S_rr t_i)``; 1 where it fits."""
    vecs, _ = model.unpack(theta)
    t = (vecs @ model.ref_pinv)[0]                                   # (nu, nr)
    r = model.residual(np.atleast_2d(theta))[0]                      # (B, nu, nr)
    srr = model._srr
    sur = r + np.einsum("ij,bjk->bik", t, srr)
    num = np.einsum("bij,ij->bi", sur, t)
    den = np.einsum("ij,bjk,ik->bi", t, srr, t).real
    return num / den


def band_coherence(spectra):
    """(B, n_u) mean multiple coherence of each SUT channel in each band."""
    mc = spectra.multiple_coherence()                                 # (nu, F)
    return np.stack([mc[:, spectra.band_of == b].mean(axis=1) for b in range(spectra.n_bands)])


def ratio_weights(spectra):
    """(B, n_u) inverse variance of ``log q`` per band (bins x segments x
    signal-to-noise)."""
    coh = np.clip(band_coherence(spectra), 1e-6, 1 - 1e-9)
    n = spectra.bins_per_band[:, None] * spectra.n_segments
    return n * coh / (1 - coh)


def locate(model, theta):
    """Where the model at ``theta`` (with its noise model set) misfits.

    Returns dict with ``misfit`` (B, n_u), ``p_value`` (B, n_u), ``flag``
    (B, n_u) booleans and ``mismatch``: contiguous runs of flagged bands as
    ``{"band_hz", "channels", "p_value", "misfit_max"}``."""
    sp = model.spectra
    v = model.standardized_band_residuals(theta)
    nr = sp.n_r
    p = gamma.sf(nr * v, nr)
    flag = p < ALPHA / p.size
    ids = [b.channel_id for b in model.blocks]
    runs = []
    for b, e in _runs(flag.any(axis=1)):
        runs.append({"band_hz": [float(sp.band_edges[b]), float(sp.band_edges[e])],
                     "channels": [ids[i] for i in np.flatnonzero(flag[b:e].any(axis=0))],
                     "p_value": float(p[b:e].min()),
                     "misfit_max": float(v[b:e].max())})
    return {"misfit": v, "p_value": p, "flag": flag, "mismatch": runs}


def segment_timing(model, theta):
    """Per-segment timing residual (s, relative to the record's mean) and a
    weight, from the phase of each segment's band cross-spectra against the
    model's prediction: the raw material of the clock-drift signature."""
    sp = model.spectra
    nu = sp.n_u
    vecs, _ = model.unpack(theta)
    t = (vecs @ model.ref_pinv)[0]
    seg = sp.per_segment
    c = np.einsum("kbij,ij->kb", seg[:, :, :nu, nu:], t)               # (K, B)
    mean_phase = np.angle(c.sum(axis=0))
    phase = np.angle(c * np.exp(-1j * mean_phase)[None])
    w = ratio_weights(sp).sum(axis=1)
    # effective frequency of each band's phase: bins weighted by the
    # predicted cross-power (the geometric band centre would bias tau)
    power = np.abs(np.einsum("fij,ij->f", sp.total[:, :nu, nu:], t))
    f = np.bincount(sp.band_of, power * sp.freqs, sp.n_bands) / np.bincount(
        sp.band_of, power, sp.n_bands)
    tau = -np.sum(w * f * phase, axis=1) / (2 * np.pi * np.sum(w * f * f))
    times = (sp.segment_starts + sp.nperseg / 2.0) / sp.fs
    return times, tau, np.ones_like(tau)


# --- candidates -------------------------------------------------------------

def _candidates(model, free, current, drift=None):
    """(key, effect, grid of starting parameters) for every applicable
    catalogue entry not already in ``current`` (list of effects)."""
    sp = model.spectra
    rows = list(range(sp.n_u))
    fmin, fmax = float(sp.band_edges[0]), float(sp.band_edges[-1])
    have = {_key(e) for e in current}
    out = []
    span = min(5.0, 0.5 / fmin)
    step = 0.05 / fmax
    if not any(e.name == "clock_drift" for e in current):
        out.append(("timing_offset", physics.TimingOffset(rows),
                    np.arange(-span, span + step, step)[:, None]))
    if _drift_candidate(model, drift):
        taus = np.arange(-span, span + step, step)
        out.append(("clock_drift", physics.ClockDrift(rows, sp),
                    np.column_stack([taus, np.full(taus.size, drift["ppm"])])))
    norm = model.blocks[0].family.norm_freq if model.blocks[0].family is not None else 1.0
    x = np.r_[np.geomspace(0.03 / fmax, 3.0 / fmin, 60)]
    for which in ("sut", "ref"):
        n = sum(1 for e in current if e.name == "extra_pole" and e.which == which)
        e = physics.ExtraPole(rows, which, norm)
        e.index = n + 1
        if n:   # unique parameter names for a second pole on the same sensor
            e.param_names = (f"inverse_corner_s_{n + 1}",)
        out.append((_key(e), e, x[:, None]))
    if free == "none":
        for i, b in enumerate(model.blocks):
            out.append((f"gain_error:{i}", physics.GainError(i, b.channel_id),
                        np.linspace(-0.6, 0.6, 61)[:, None]))
    return [c for c in out if c[0] not in have]


def _drift_candidate(model, drift):
    """Whether a clock drift is tried: the per-segment timing trend passes
    the screen and the spectra have enough time blocks."""
    bt = model.spectra.block_totals
    return (drift is not None and abs(drift["t_stat"]) > DRIFT_T and bt is not None
            and bt.shape[0] >= MIN_TIME_BLOCKS)


def _key(effect):
    if effect.name == "extra_pole":
        k = getattr(effect, "index", 1)
        return f"extra_pole:{effect.which}" + (f"#{k}" if k > 1 else "")
    if effect.name == "gain_error":
        return f"gain_error:{effect.rows[0]}"
    return effect.name


def _with(model, effects, per_block=False):
    """``model`` with ``effects`` and its noise model. Once a time-dependent
    effect is in, the likelihood is per time block (and stays so, so that the
    models a search compares use the same data)."""
    m = Model(model.spectra, model.ref_vectors, model.blocks, model.priors, effects=effects,
              per_block=per_block or model.per_block)
    if model.noise is not None:
        m.adopt_noise(model.noise)
    return m


def _theta_base(model, theta):
    """The channel-block part of ``theta`` (effects stripped)."""
    n = sum(b.n_params for b in model.blocks)
    return np.asarray(theta)[:n]


def _effect_params(model, theta):
    return {_key(e): np.asarray(theta)[sl] for e, sl in zip(model.effects, model.effect_slices)}


def fit_candidate(cur_model, cur_theta, effects, grid, new_index):
    """Least-squares fit of ``cur_model`` extended by ``effects`` (the new
    effect at ``new_index`` starts at the best point of ``grid`` under the
    current noise model). Returns (model, theta, cov) or None when the fit
    leaves the effect's prior support."""
    m = _with(cur_model, effects)
    old = _effect_params(cur_model, cur_theta)
    base = list(_theta_base(cur_model, cur_theta))
    pieces, new_slice, i = [], None, len(base)
    for k, e in enumerate(effects):
        if k == new_index:
            pieces.append(np.zeros(e.n_params))
            new_slice = slice(i, i + e.n_params)
        else:
            pieces.append(old.get(_key(e), np.zeros(e.n_params)))
        i += e.n_params
    theta0 = np.concatenate([base] + pieces)
    trial = np.repeat(theta0[None], len(grid), axis=0)
    trial[:, new_slice] = grid
    lp = m.log_prior(trial)
    ok = np.isfinite(lp)
    ll = np.full(len(grid), -np.inf)
    ll[ok] = m.log_likelihood(trial[ok])
    new = effects[new_index]
    best = None
    for theta0 in _starts(trial, ll, N_STARTS if getattr(new, "multimodal", False) else 1):
        try:
            theta, cov = least_squares_fit(m, theta0)
        except Exception:
            continue
        if not np.isfinite(m.log_prior(theta))[0] or not np.all(np.isfinite(np.diag(cov))):
            continue
        # starts are compared under one noise model, the current model's
        own = m.noise
        m.adopt_noise(cur_model.noise)
        fit_ll = float(m.log_likelihood(theta)[0])
        if best is None or fit_ll > best[0]:
            best = (fit_ll, theta, cov, own)
    if best is None:
        return None
    _, theta, cov, m.noise = best
    sp = m.spectra
    if hasattr(new, "identifiable") and not new.identifiable(theta[new_slice], sp.band_edges[0],
                                                             sp.band_edges[-1]):
        return None
    return m, theta, cov


def _starts(trial, ll, n):
    """The ``n`` best local maxima of ``ll`` along the grid ``trial`` (a
    delay's likelihood is multimodal: one least-squares run from the grid's
    best point can end in a neighbouring mode)."""
    inner = np.r_[True, ll[1:] >= ll[:-1]] & np.r_[ll[:-1] >= ll[1:], True] & np.isfinite(ll)
    idx = np.flatnonzero(inner)
    idx = idx[np.argsort(ll[idx])[::-1]][:n]
    return [trial[i] for i in idx] or [trial[int(np.argmax(ll))]]


def _best_loglik(model, starts):
    """Largest log-likelihood of ``model`` under its (fixed) noise model,
    maximised by least squares from each of ``starts``."""
    return _refit(model, starts)[0]


def _refit(model, starts):
    """(log-likelihood, theta) of the best least-squares refit of ``model``
    from ``starts`` under its fixed noise model."""
    if model.ndim == 0:
        return float(model.log_likelihood(np.zeros((1, 0)))[0]), np.zeros(0)
    fac = model.noise.cholesky()
    lo, hi = _bounds(model)
    bounded = bool(np.isfinite(lo).any())
    best = (-np.inf, None)
    for start in starts:
        res = least_squares(model.whitened_residual, np.clip(start, lo + 1e-9, hi - 1e-9),
                            args=(fac,), method="trf" if bounded else "lm",
                            bounds=(lo, hi) if bounded else (-np.inf, np.inf),
                            xtol=1e-12, ftol=1e-12, gtol=1e-12)
        ll = float(model.log_likelihood(res.x)[0])
        if ll > best[0]:
            best = (ll, res.x)
    return best


def held_orientation_loglik(model, theta, axes):
    """Log-likelihood with every SUT axis held at ``axes`` (n_u, 3) and the
    response parameters re-fitted, under ``model``'s noise model."""
    blocks = [replace(b, manifold=Fixed(np.asarray(a, float))) for b, a in zip(model.blocks, axes)]
    held = Model(model.spectra, model.ref_vectors, blocks, model.priors)
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
    if finding["name"] == "channel_swap":
        alt[rows] = nominal[rows[::-1]]
    else:
        alt[rows] = -nominal[rows]
    return 2.0 * (held_orientation_loglik(model, theta, alt)
                  - held_orientation_loglik(model, theta, nominal))


def score(cur_model, cur_theta, ext_model, ext_theta):
    """BIC gain of ``ext_model`` over ``cur_model`` under the extended
    model's noise model (the current model re-optimised under it)."""
    cur = _with(cur_model, cur_model.effects, per_block=ext_model.per_block)
    cur.adopt_noise(ext_model.noise)
    # start from the current optimum and from the extended optimum's shared
    # parameters (the plug-in noise moves the optimum), keep the better
    ext_params = _effect_params(ext_model, ext_theta)
    shared = np.concatenate([_theta_base(ext_model, ext_theta)] + [
        ext_params.get(_key(e), np.asarray(cur_theta)[sl])
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


def search(model, theta, free, log=None, drift=None):
    """Greedy search: add the best-scoring catalogue effect while its BIC
    gain exceeds :data:`BIC_KEEP`. Returns (model, theta, cov, steps)."""
    cur, th, cov = model, theta, None
    steps = []
    while len(cur.effects) < MAX_EFFECTS:
        tried = []
        for key, effect, grid in _candidates(cur, free, cur.effects, drift):
            effects = list(cur.effects)
            if key == "clock_drift":      # nests timing_offset: replaces it
                effects = [e for e in effects if e.name != "timing_offset"]
            effects.append(effect)
            fit = fit_candidate(cur, th, effects, grid, len(effects) - 1)
            if fit is None:
                tried.append({"effect": key, "delta_bic": None,
                          "note": "left the prior support or not identifiable in the band"})
                continue
            s = score(cur, th, fit[0], fit[1])
            tried.append({"effect": key, **s, "fit": fit})
            if log:
                log(f"  {key:18s} dBIC {s['delta_bic']:10.1f}")
        good = [t for t in tried if t.get("delta_bic") is not None]
        best = max(good, key=lambda t: t["delta_bic"], default=None)
        steps.append([{k: v for k, v in t.items() if k != "fit"} for t in tried])
        if best is None or best["delta_bic"] <= BIC_KEEP:
            break
        timing = next((t for t in good if t["effect"] == "timing_offset"), None)
        if best["effect"] == "clock_drift" and timing is not None:
            # clock drift nests a constant offset: it must beat it, not only the current model
            s = score(timing["fit"][0], timing["fit"][1], best["fit"][0], best["fit"][1])
            if log:
                log(f"  clock_drift over timing_offset dBIC {s['delta_bic']:10.1f}")
            if s["delta_bic"] <= BIC_KEEP and timing["delta_bic"] > BIC_KEEP:
                best = timing
        cur, th, cov = best["fit"]
        steps[-1].append({"kept": best["effect"], "delta_bic": best["delta_bic"]})
    return cur, th, cov, steps


# --- posterior of the final model --------------------------------------------

def posterior_of(model, theta, cov, meta, not_estimable, free, seed=0, mcmc=True,
                 progress=False, n_laplace=4000, **sample_kw):
    """A :class:`Posterior` of ``model`` (with effects) from MCMC
    (:func:`bayescal.fit.sample`) or, with ``mcmc=False``, from its Laplace
    approximation (Gaussian at the least-squares point; stated in meta)."""
    if mcmc:
        chain = sample(model, theta, cov, seed=seed, progress=progress, **sample_kw)
        samples, lp = chain.samples, chain.log_prob
        conv = {"tau": chain.tau, "ess": chain.ess, "rhat": chain.rhat,
                "acceptance": chain.acceptance, "n_steps": chain.n_steps,
                "n_walkers": chain.n_walkers, "burn": chain.burn, "converged": chain.converged}
        trace = chain.trace
    else:
        rng = np.random.default_rng(seed)
        samples = rng.multivariate_normal(theta, cov, size=n_laplace)
        lp = model.log_prob(samples)
        samples, lp = samples[np.isfinite(lp)], lp[np.isfinite(lp)]
        one = np.ones(model.ndim)
        conv = {"tau": one, "ess": one * len(samples), "rhat": one, "acceptance": 1.0,
                "n_steps": 0, "n_walkers": 0, "burn": 0, "converged": True}
        trace = None
        meta = dict(meta, approximation="Laplace (Gaussian at the least-squares point), no MCMC")
    vecs, _ = model.unpack(samples)
    resp = model.response_values(samples) if free != "none" else {}
    kinds = [{2: "sphere", 1: "circle", 0: "fixed"}[b.manifold.n_params] for b in model.blocks]
    post = Posterior(channel_ids=[b.channel_id for b in model.blocks], kinds=kinds, vectors=vecs,
                     response=resp, samples=samples, names=model.names, log_prob=lp,
                     convergence=conv, meta=dict(meta, effects=[e.name for e in model.effects]),
                     not_estimable=not_estimable, trace=trace,
                     diagnostics=diagnostics(model, np.median(samples, axis=0)))
    post.model = model
    return post


# --- the whole diagnosis -------------------------------------------------------

def _nominal_vectors(meta, ids):
    nom = meta.get("nominal", {})
    return np.array([unit_vector(nom[c]["azimuth_deg"], nom[c]["dip_deg"]) for c in ids])


def _effect_entry(model, effect, sl, samples, step_score):
    phys = effect.physical(samples[:, sl])
    params = {k: interval_summary(v) for k, v in phys.items()}
    med = {k: v["median"] for k, v in params.items()}
    ids = [model.blocks[r].channel_id for r in effect.rows]
    if effect.name == "extra_pole":
        params["which"] = effect.which
    return {"name": effect.name, "channels": ids, "parameters": params,
            "score_gain": step_score, "explanation": effect.explain(med)}


def diagnose(base, seed=0, mcmc=True, progress=False, log=None, **sample_kw):
    """Diagnose a base fit.

    ``base`` is a :class:`Posterior` from :func:`bayescal.pipeline.calibrate`
    (with ``.model`` and ``.theta_ls`` attached). Returns a
    :class:`Diagnosis`.
    """
    model0 = base.model
    free = base.meta.get("free_response", "none")
    th0 = base.theta_ls
    model0.estimate_noise(th0)
    before = locate(model0, th0)
    ids = [b.channel_id for b in model0.blocks]
    sp = model0.spectra
    q = band_ratio(model0, th0)
    sig = physics.signatures(sp.band_centres, q, ratio_weights(sp))
    times, tau_k, w_k = segment_timing(model0, th0)
    sig["clock_drift"] = physics.drift_signature(times, tau_k, w_k)
    # when a drift is a candidate, every model of the search is scored on the
    # per-time-block likelihood (candidates ranked on the same data)
    start = _with(model0, [], per_block=_drift_candidate(model0, sig["clock_drift"]))
    if start.per_block:
        start.estimate_noise(th0)
    model, th, cov, steps = search(start, th0, free, log=log, drift=sig["clock_drift"])
    if cov is None:
        model, th, cov = model0, th0, least_squares_fit(model0, th0)[1]
    after = locate(model, th)
    # the base model's misfit under the final noise model: the base's own
    # noise estimate is inflated by the misfit it leaves (before/after on one scale)
    common = _with(model0, [], per_block=model.per_block)
    common.adopt_noise(model.noise)
    before_common = locate(common, _refit(common, (th0,))[1])
    if model.effects:
        final = posterior_of(model, th, cov, base.meta, base.not_estimable, free, seed=seed,
                             mcmc=mcmc, progress=progress, **sample_kw)
    else:       # nothing to add to the response model: the final fit is the base fit
        final = base
    kept = {s["kept"]: s["delta_bic"] for step in steps for s in step if "kept" in s}
    effects = []
    for e, sl in zip(model.effects, model.effect_slices):
        entry = _effect_entry(model, e, sl, final.samples, kept.get(_key(e)))
        entry["signature"] = sig.get(_key(e), {})
        effects.append(entry)
    # orientation effects: fitted axes against the metadata axes
    fitted = np.median(base.vectors, axis=0)
    fitted /= np.linalg.norm(fitted, axis=1, keepdims=True)
    nominal = _nominal_vectors(base.meta, ids) if base.meta.get("nominal") else None
    if nominal is not None:
        for f in physics.orientation_findings(fitted, nominal, ids):
            gain = orientation_score(model0, th0, nominal, f)
            sig[f"{f['name']}:{','.join(f['channels'])}"] = {"delta_bic": gain}
            if gain <= BIC_KEEP:
                continue
            ang = {c: interval_summary(np.degrees(np.arccos(np.clip(
                base.vectors[:, r] @ nominal[r], -1, 1))))
                for c, r in zip(f["channels"], f["rows"])}
            effects.append({"name": f["name"], "channels": f["channels"],
                            "parameters": {"angle_to_metadata_axis_deg": ang},
                            "score_gain": gain, "explanation": f["explanation"]
                            + "; the free orientation fit already models it"})
        horizontal = np.abs(np.degrees(np.arcsin(np.clip(nominal[:, 2], -1, 1)))) < 45
        t = tilt.tilt_test(sp, horizontal, bic_keep=BIC_KEEP)
        sig["tilt_noise"] = t     # with the noise-spectrum misfit before/after (misfit_base/_tilt)
        if t["applicable"] and t["kept"] and t["channels"]:
            params = {"alpha": t["alpha"]}
            for i in t["channels"]:
                params[f"noise_to_signal_lowest_band:{ids[i]}"] = \
                    t["per_channel"][str(i)]["nsr_lowest_band"]
            effects.append({"name": "tilt_noise", "channels": [ids[i] for i in t["channels"]],
                            "parameters": params, "score_gain": t["delta_bic"],
                            "explanation": t["explanation"] + "; it is noise, not a response "
                            "error: the per-band noise model carries it (those bands weigh "
                            "less), so the orientation and response estimates do not move",
                            "signature": sig["tilt_noise"]})
    return Diagnosis(base=base, final=final, before=before, after=after, effects=effects,
                     before_common=before_common,
                     steps=steps, signatures=sig, band_edges=sp.band_edges, ids=ids,
                     ratio_before=q, ratio_after=band_ratio(model, th))


def _runs(mask):
    """(first, end) band indices of each run of True in ``mask``."""
    edges = np.flatnonzero(np.diff(np.r_[0, mask.astype(int), 0]))
    return list(zip(edges[::2], edges[1::2]))


class Diagnosis:
    """Everything :func:`diagnose` found; ``summary()`` is diagnosis.json."""

    def __init__(self, **kw):
        self.__dict__.update(kw)

    @property
    def names(self):
        return [e["name"] for e in self.effects]

    def unexplained(self):
        """Sentences for mismatch that remains after the final model."""
        return [f"unexplained mismatch in band {m['band_hz'][0]:.3g}-{m['band_hz'][1]:.3g} Hz "
                f"on channels {', '.join(m['channels'])} (p = {m['p_value']:.2g}, misfit up to "
                f"{m['misfit_max']:.2g} times its expectation)" for m in self.after["mismatch"]]

    def movements(self):
        """How each channel's orientation (and response) moved from the
        base fit to the final fit (median differences)."""
        b, f = self.base.summary()["channels"], self.final.summary()["channels"]
        out = {}
        for cid in b:
            d = {}
            for key in ("azimuth_deg", "dip_deg"):
                if "median" in b[cid][key] and not b[cid][key].get("undefined"):
                    d[key] = f[cid][key]["median"] - b[cid][key]["median"]
            for key, v in b[cid].get("response", {}).items():
                d[key] = f[cid]["response"][key]["median"] - v["median"]
            out[cid] = d
        return out

    def sentences(self):
        """The finding in plain words."""
        out = []
        edges = self.band_edges
        for e in self.effects:
            s = e["explanation"]
            if e.get("score_gain") is not None and "BIC" not in s:
                s += f" (BIC gain {e['score_gain']:.0f})"
            out.append(s)
        fixed = self.before_common["flag"].any(axis=1) & ~self.after["flag"].any(axis=1)
        if fixed.any() and any(e.get("score_gain") for e in self.effects):
            before = self.before_common["misfit"][fixed].max()
            after = self.after["misfit"][fixed].max()
            where = ", ".join(f"{edges[a]:.3g}-{edges[b]:.3g}" for a, b in _runs(fixed))
            out.append(f"modelling {'it' if len(self.effects) == 1 else 'them'} removes the "
                       f"misfit in {where} Hz (largest standardised misfit there "
                       f"{before:.3g} -> {after:.3g}, both under the final model's noise model)")
        if any(e.get("score_gain") for e in self.effects) and self.final is not self.base:
            b, a = self.before_common["misfit"], self.after["misfit"]
            out.append(f"over the whole {edges[0]:.3g}-{edges[-1]:.3g} Hz band the standardised "
                       f"misfit falls from median {np.median(b):.3g} (largest {b.max():.3g}) to "
                       f"median {np.median(a):.3g} (largest {a.max():.3g}); 1 means a fit "
                       "within the noise")
        moves = self.movements()
        big = [(c, k, v) for c, d in moves.items() for k, v in d.items()
               if k == "azimuth_deg" and abs(v) > 0.05]
        if big and any(e.get("score_gain") for e in self.effects):
            out.append("it moves " + ", ".join(f"{c}'s azimuth by {v:+.2f} degree"
                                               for c, _, v in big))
        if not self.effects and not self.after["mismatch"]:
            out.append("no mismatch: the model describes the recordings within their noise")
        out += self.unexplained()
        return out

    def summary(self):
        def cells(loc):
            return {"misfit": loc["misfit"], "p_value": loc["p_value"]}
        steps = [[{k: v for k, v in t.items()} for t in step] for step in self.steps]
        return {"schema": SCHEMA, "mismatch": self.before["mismatch"],
                "effects": self.effects, "unexplained": self.after["mismatch"],
                "summary": self.sentences(),
                "per_band": {"band_edges_hz": self.band_edges, "channels": self.ids,
                             "before": cells(self.before), "after": cells(self.after),
                             "before_under_final_noise": cells(self.before_common),
                             "ratio_amplitude_before": np.abs(self.ratio_before),
                             "ratio_phase_deg_before": np.degrees(np.angle(self.ratio_before)),
                             "ratio_amplitude_after": np.abs(self.ratio_after),
                             "ratio_phase_deg_after": np.degrees(np.angle(self.ratio_after))},
                "signatures": self.signatures, "search": steps,
                "movements": self.movements(),
                "criteria": {"alpha_familywise": ALPHA, "bic_keep": BIC_KEEP,
                             "score": "BIC difference under the extended model's noise model"},
                "base": self.base.summary(), "final": self.final.summary()}
