"""From spectra to posterior samples: global closed-form start, least-squares
refinement, then emcee run until converged (:func:`bayescal.core.sampling.mcmc.sample`,
a differential-evolution burn-in followed by an independence move with a
frozen t proposal; the convergence rule is stated there).
"""
from __future__ import annotations

import warnings
from dataclasses import dataclass

import numpy as np

from .. import budget as work
from ..progress import shown, stage
from ..model import misfit_scale, refnoise
from ..response import pendulum
from ..threads import single_threaded_blas
from ...errors import BudgetWarning, FitError
from .assemble import assemble_posterior, plugin_meta
from .leastsq import refine
from ..orientation.geometry import Circle, Fixed, Sphere
from ..model.eiv import EIVModel
from ..model.likelihood import ChannelBlock, Model
from ..priors import Priors
from .unconstrained import prior_bounds

#: A SUT channel is fitted against a two- or one-channel reference only when
#: its nominal axis lies within this angle (degrees) of the reference's span.
SPAN_TOLERANCE_DEG = 30.0


def closed_form_transfer(spectra):
    """Global start: the real 3x3 (n_u x n_r) transfer ``T = Re(S_ur) Re(S_rr)^-1``
    from all bands together. Independent of any nominal orientation, so a
    sensor turned round, or with reversed or swapped channels, is found."""
    s = spectra.band_sums().sum(axis=0)
    nu = spectra.n_u
    return np.real(s[:nu, nu:]) @ np.linalg.inv(np.real(s[nu:, nu:]))


def span_basis(ref_vectors):
    """Orthonormal basis (rows) of the span of the reference axes."""
    _, sv, vt = np.linalg.svd(ref_vectors)
    rank = int(np.sum(sv > 1e-6 * sv[0]))
    return vt[:rank], vt[rank:]


def _plane_circle(basis):
    """A Circle on the plane spanned by ``basis`` (2 x 3), with e1 the
    projection of North (so the angle is the azimuth for a horizontal plane)."""
    normal = np.cross(basis[0], basis[1])
    if normal[2] < 0:
        normal = -normal
    north = np.array([1.0, 0.0, 0.0])
    e1 = north - normal * (normal @ north)
    if np.linalg.norm(e1) < 1e-6:
        e1 = np.array([0.0, 1.0, 0.0]) - normal * normal[1]
    e1 /= np.linalg.norm(e1)
    return Circle(e1=e1, e2=np.cross(normal, e1))


@dataclass
class Setup:
    """What can be estimated, and where the fit starts."""

    model: Model
    theta0: np.ndarray
    fitted: list            # indices of the SUT channels in the model
    not_estimable: dict     # SUT channel id -> reason


def build_model(spectra, ref_vectors, sut_nominal_vectors, families, free="none", *,
                priors=Priors(), ref_noise=None, known_noise=None):
    """Decide each SUT channel's parametrisation and the starting point.

    Parameters
    ----------
    spectra : CrossSpectra over all SUT channels.
    ref_vectors : (n_r, 3) reference axes.
    sut_nominal_vectors : (n_u, 3) SUT axes from its metadata: used only to
        decide which channels a partial (one- or two-channel) reference can
        see, never as a starting point.
    families : per SUT channel a :class:`TwoPoleFamily`, a gain-only
        :class:`ScaleFamily` (``flat`` metadata) or None.
    free : "none" (gains held at their metadata values), "gain" (each
        channel's gain free: the relative gain is fitted / metadata) or
        "all" (period, damping and gain).
    ref_noise : how the reference's self-noise enters: "quiet" (negligible,
        the base :class:`Model`), "estimate" or "equal" (:class:`EIVModel`,
        see :mod:`bayescal.core.model.refnoise`); None: "quiet"; "fixed" with
        ``known_noise`` (B, n_r): the reference's self-noise given.
    """
    ref_vectors = np.asarray(ref_vectors, float)
    basis, _ = span_basis(ref_vectors)
    v_hat = closed_form_transfer(spectra) @ ref_vectors                # (nu, 3)
    fitted, skipped = _estimable(spectra, basis, v_hat, sut_nominal_vectors)
    _check_families(families, fitted, free)
    rank = basis.shape[0]
    sub = spectra.select(fitted)
    blocks, theta0 = [], []
    for i in fitted:
        v = v_hat[i]
        norm = np.linalg.norm(v)
        if rank == 3:
            manifold = Sphere(v0=v / norm)
        elif rank == 2:
            manifold = _plane_circle(basis)
        else:
            manifold = Fixed(v0=np.sign(v @ basis[0]) * basis[0])
        theta0.extend(manifold.params(v / norm))
        fam = families[i]
        if free == "gain":
            theta0.append(np.log(fam.gain * norm))
        elif free == "all":
            theta0.extend([1.0, 1.0, np.log(fam.gain * norm)])     # nominal c0_rel, c1_rel
        blocks.append(ChannelBlock(channel_id=str(sub.sut_ids[len(blocks)]) if sub.sut_ids
                                   else str(i), manifold=manifold, family=fam, free=free))
    if ref_noise in (None, "quiet"):
        model = Model(sub, ref_vectors, blocks, priors)
    else:
        model = EIVModel(sub, ref_vectors, blocks, priors, ref_noise=ref_noise,
                         known_noise=known_noise)
    return Setup(model=model, theta0=np.asarray(theta0, float), fitted=fitted,
                 not_estimable=skipped)


def _estimable(spectra, basis, v_hat, sut_nominal_vectors):
    """(indices of the SUT channels that can be estimated, {channel id:
    why not} of the others): outside a partial reference's span, or no
    signal coherent with the reference (``v_hat``: the closed-form axes)."""
    rank = basis.shape[0]
    fitted, skipped = [], {}
    for i, cid in enumerate(spectra.sut_ids or range(spectra.n_u)):
        if rank < 3:
            vn = np.asarray(sut_nominal_vectors[i], float)
            inside = np.linalg.norm(basis @ vn)
            if inside < np.cos(np.radians(SPAN_TOLERANCE_DEG)):
                skipped[str(cid)] = (f"its axis lies outside the span of the {rank} reference "
                                     "channel(s); the reference cannot see it")
                continue
        if np.linalg.norm(v_hat[i]) == 0 or not np.all(np.isfinite(v_hat[i])):
            skipped[str(cid)] = "no signal coherent with the reference"
            continue
        fitted.append(i)
    if not fitted:
        raise FitError("no SUT channel can be estimated from this reference")
    return fitted, skipped


def response_fit_refusal(families, free):
    """Why a fit of ``free`` ("none", "gain" or "all") refuses channels of
    these response ``families`` (one per fitted SUT channel), or None when
    it accepts them: the one rule :func:`build_model` applies, which the
    criticism's advice is checked against."""
    if free != "none" and any(f is None for f in families):
        return "gain fitting needs a response with a gain on every fitted channel"
    if free == "all" and any(not np.isfinite(f.period_s) for f in families):
        return ("fitting period and damping (--fit-response all) needs a poles-and-zeros "
                "first stage with a pendulum pair on every fitted channel ('flat' has "
                "none: use the default, which fits each channel's gain)")
    return None


def _check_families(families, fitted, free):
    """Refuse a response fit the fitted channels' metadata cannot carry."""
    why = response_fit_refusal([families[i] for i in fitted], free)
    if why:
        raise FitError(why)


def least_squares_fit(model, theta0, iterations=2, jac=None, budget=None):
    """Refine ``theta0`` by least squares on the whitened residual (Levenberg-
    Marquardt, :func:`bayescal.core.fit.leastsq.refine`), re-estimating the
    noise model after each pass.
    ``jac``: scipy's ``"2-point"``, a callable such as
    :func:`bayescal.core.model.jacobian.forward_jacobian`'s, or None: ``"2-point"``
    for the base model (whose numbers are fixed) and the one-call forward
    Jacobian for the errors-in-variables model (its residual costs several
    times the base model's; the columns agree to rounding).

    Returns ``(theta, covariance)``; the covariance is the inverse Fisher
    information ``(2 J^T J)^-1`` (``-log L`` is the squared residual norm),
    the pendulum priors' included
    (:func:`bayescal.core.model.jacobian.least_squares_objective`): along a
    direction the data hardly fix, the point stays where the prior puts it.
    ``budget``: a :class:`bayescal.core.budget.Budget`; once spent the
    point is the best one evaluated (:func:`bayescal.core.fit.leastsq.refine`).
    """
    from ..model.jacobian import least_squares_objective
    if jac is None:
        from ..model.jacobian import forward_jacobian
        jac = forward_jacobian(model) if isinstance(model, EIVModel) else "2-point"
    fun, jac = least_squares_objective(model, jac)
    lo, hi = prior_bounds(model)
    return refine(fun, theta0, lo, hi, model.estimate_noise, iterations,
                  noise_args=lambda: (model.noise.cholesky(),), method="lm", jac=jac,
                  budget=budget)


def fit_spectra(spectra, ref_vectors, sut_nominal_vectors, families, *, free="none",
                priors=Priors(), seed=0, progress=True, meta=None, ref_noise=None,
                misfit_shape=None, known_noise=None, inflation_floor=None, **sample_kw):
    """Whole inference from spectra: start, least squares, sampling.

    ``misfit_shape``: shape ``a`` of the per-band noise-scale prior
    (:mod:`bayescal.core.model.misfit_scale`); None: its default
    ``MISFIT_SHAPE``; ``inf``: the Gaussian likelihood. ``inflation_floor``:
    None, or (B,) a lower bound on each band's noise inflation
    (:mod:`bayescal.core.model.inflation`; :mod:`bayescal.record.pooling`
    sets it from the windows of a record).

    ``ref_noise``: None (the default) is
    :func:`bayescal.core.model.refnoise.recommended_mode` of the pair: "estimate"
    (the reference's self-noise estimated, unbiased whatever the split of
    noise) with two or more channels a side, "quiet" otherwise; the mode
    used and whether it was the default are in the meta's
    ``reference_noise``. ``known_noise`` (B, n_r): the
    reference's self-noise given as band sums
    (:func:`bayescal.core.model.refnoise.band_sums_of_psd`), with ``ref_noise="fixed"``.

    Returns a :class:`bayescal.core.posterior.state.FitState`
    (:func:`bayescal.core.fit.assemble.assemble_posterior`); the least-squares
    point is also in its meta's ``least_squares``.
    """
    from .rotation import fit_rotation, orthogonal_pair

    pair = orthogonal_pair(ref_vectors, sut_nominal_vectors) if free != "all" else None
    if pair is not None:   # one horizontal reference channel: ASL's orthogonal rotation
        # (gains held: one reference channel cannot tell the two horizontals'
        # gains from their rotation; a gain common to both does not bias it)
        if ref_noise not in (None, "quiet"):
            raise FitError(f"--ref-noise {ref_noise} is not available with a one-channel "
                           "horizontal reference (ASL's orthogonal-pair rotation, which assumes "
                           "the reference quiet)")
        return fit_rotation(spectra, ref_vectors, pair, seed=seed, meta=meta,
                            inflation_floor=inflation_floor)
    chosen_by = "user"
    if ref_noise is None:       # the default: unbiased whatever the split of noise
        from ..model.refnoise import recommended_mode
        ref_noise, chosen_by = recommended_mode(spectra.n_r, spectra.n_u), "default"
    setup = build_model(spectra, ref_vectors, sut_nominal_vectors, families, free,
                        priors=priors, ref_noise=ref_noise, known_noise=known_noise)
    setup.model.misfit_shape = (misfit_scale.MISFIT_SHAPE if misfit_shape is None
                                else misfit_shape)
    setup.model.inflation_floor = inflation_floor
    if setup.model.ndim == 0:
        raise FitError("nothing to estimate: against this reference the SUT channel's axis is "
                       "fixed to the reference's (one channel each), so only its response can "
                       "be estimated: do not hold it with --fit-response none")
    run = _sample(setup, sut_nominal_vectors, seed=seed, progress=progress, **sample_kw)
    meta = dict(meta or {})
    meta.update(_fit_meta(run, spectra, free, priors, chosen_by))
    return assemble_posterior(run.model, run.chain.samples, run.chain.log_prob,
                              run.chain.convergence(), meta, free, names=run.target.names,
                              full=run.full, theta_ls=run.theta_ls,
                              not_estimable=setup.not_estimable, trace=run.chain.trace)


@dataclass
class _Run:
    """What the least squares, the mode search and the sampler made."""

    model: Model
    theta_ls: np.ndarray
    target: object
    chain: object
    full: np.ndarray
    multimodal: dict
    separation: dict
    set_by_prior: dict
    sensitivity: dict
    budgets: list
    gain_bounds: dict = None


def _sample(setup, sut_nominal_vectors, *, seed, progress, **sample_kw):
    """Least squares, the search for other modes, the parameters held for
    want of information, the chain, and the flags on what the prior set."""
    from .unconstrained import (REFIT_WORK, describe_late, full_samples, hold_unconstrained,
                                late_flags)
    with single_threaded_blas(), shown(progress):
        model, theta_ls, cov, multimodal, budgets = _optimise(setup, sut_nominal_vectors)
        separation = {}
        if getattr(model, "ref_noise", None) == "estimate":
            from ..checks.separation import gain_separation
            separation = gain_separation(model, theta_ls, cov)
        from ..checks.gain_bounds import identified_gains
        bounds = identified_gains(model, theta_ls, cov)
        # parameters the data do not constrain are held at nominal
        refit = work.Budget("refit with parameters held", REFIT_WORK, helps=_budget_help(model))
        target, start, cov, theta_ls, set_by_prior = hold_unconstrained(model, theta_ls, cov,
                                                                        budget=refit)
        budgets = budgets + _spent_refit(refit, set_by_prior)
        from ..sampling.mcmc import sample
        chain = sample(target, start, cov, seed=seed, progress=progress,
                       **{"laplace": True, **sample_kw})
    full = full_samples(target, chain.samples)
    held = [j for j, n in enumerate(model.names) if n in set_by_prior]
    set_by_prior.update(describe_late(model, late_flags(model, full, skip=held)))
    sensitivity = _prior_sensitivity(model, full, n_eff=chain.convergence().ess_min)
    set_by_prior.update(pendulum.set_by_prior_entries(sensitivity))
    return _Run(model=model, theta_ls=theta_ls, target=target, chain=chain, full=full,
                multimodal=multimodal, separation=separation, set_by_prior=set_by_prior,
                sensitivity=sensitivity, budgets=budgets, gain_bounds=bounds)


def _spent_refit(refit, set_by_prior):
    """The held-parameter refit's budget summary (none when nothing was
    held), with a :class:`BudgetWarning` once it is spent."""
    if not set_by_prior:
        return []
    if refit.ended_by:
        warnings.warn(f"budget spent: {refit.note()}", BudgetWarning, stacklevel=4)
    return [refit.summary()]


def _budget_help(model):
    """What helps a pair fit whose least squares or mode search ran out of
    its work budget: fewer parameters or fewer bands."""
    if any(b.free == "all" for b in model.blocks):
        return ("fewer parameters help (--fit-response gain: period and damping held at "
                "their metadata values), or a narrower --band")
    return "a narrower --band helps (fewer bands to fit)"


def _optimise(setup, nominal):
    """The least squares and the mode search, each within its work budget
    and saying its progress (:mod:`bayescal.core.progress`): ``(model,
    theta_ls, cov, multimodal, budgets)``, ``budgets`` each stage's
    :meth:`~bayescal.core.budget.Budget.summary`. A stage that ends by its
    budget goes on from its best point, with a :class:`BudgetWarning`."""
    helps = _budget_help(setup.model)
    from ..checks.gain_bounds import off_scale, off_scale_message
    off = off_scale(setup.model, setup.theta0)   # metadata off in scale: no gain the prior fits
    if off:
        raise FitError(off_scale_message(off))
    ls = work.Budget("least squares", work.LEAST_SQUARES_WORK, helps=helps)
    with stage("least squares", ls) as st:
        theta_ls, cov = least_squares_fit(setup.model, setup.theta0, budget=ls)
        st.result = f"{setup.model.ndim} parameters" + (", BUDGET SPENT" if ls.ended_by else "")
    ms = work.Budget("mode search", work.MODE_SEARCH_WORK, helps=helps)
    with stage("mode search", ms) as st:
        model, theta_ls, cov, multimodal = _modes(setup.model, theta_ls, cov, nominal,
                                                  setup.fitted, budget=ms)
        n = multimodal.get("starts", 1)
        st.result = (f"{len(multimodal['modes'])} mode(s) from {n - multimodal.get('not_tried', 0)}"
                     f" of {n} starts" + (", BUDGET SPENT" if ms.ended_by else ""))
    for b in (ls, ms):
        if b.ended_by:
            warnings.warn(f"budget spent: {b.note()}", BudgetWarning, stacklevel=3)
    return model, theta_ls, cov, multimodal, [ls.summary(), ms.summary()]


def _fit_meta(run, spectra, free, priors, chosen_by):
    """The meta entries of a pair fit: band, segments, noise model, the
    reference's noise, least squares, what the prior set, modes, sampler."""
    model = run.model
    return {"free_response": free, "band_hz": [float(spectra.band_edges[0]),
                                               float(spectra.band_edges[-1])],
            "band_edges_hz": spectra.band_edges, "n_segments": spectra.n_segments,
            "n_segments_possible": spectra.n_segments_possible,
            "segment_s": spectra.nperseg / spectra.fs,
            "noise_inflation": model.noise.inflation,
            "plugin_weights": plugin_meta(model),
            "reference_noise": dict(refnoise.treatment_meta(model, run.theta_ls),
                                    chosen_by=chosen_by,
                                    **({"separation": run.separation} if run.separation else {}),
                                    **({"gain_bounds": run.gain_bounds} if run.gain_bounds
                                       else {})),
            "misfit_scale": _misfit_meta(model, np.median(run.full, axis=0)),
            "least_squares": dict(zip(model.names, run.theta_ls)),
            "set_by_prior": run.set_by_prior, "multimodal": run.multimodal,
            **({"prior_sensitivity": run.sensitivity,
                "response_prior": {"period_tolerance": priors.period_tolerance,
                                   "damping_tolerance": priors.damping_tolerance,
                                   "shape": "log-normal around the metadata values"}}
               if run.sensitivity else {}),
            "sampler": run.chain.sampler,
            "budgets": run.budgets + [_sampling_budget(run.chain)]}


def _sampling_budget(chain):
    """The sampler's work as a budget's summary: the log-probability
    evaluations it made and was allowed, as its record counts them
    (:func:`bayescal.core.sampling.mcmc.sample`)."""
    return {"stage": "sampling", "unit": work.UNIT,
            "limit": int(chain.sampler["evaluation_limit"]),
            "used": int(chain.sampler["evaluations"]), "time_limit_s": None,
            "ended_by": None if chain.converged else "work"}


def _modes(model, theta_ls, cov, nominal, fitted, budget=None):
    """:func:`bayescal.core.fit.modes.search`; when another mode is the most
    probable, the fit restarts there (noise model re-estimated), both
    within ``budget``."""
    from .modes import search

    best, report = search(model, theta_ls, np.asarray(nominal, float)[fitted], budget=budget)
    if best.label.startswith("closed-form"):
        return model, theta_ls, cov, report
    theta_ls, cov = least_squares_fit(best.model, best.theta, budget=budget)
    return best.model, theta_ls, cov, report


def _prior_sensitivity(model, samples, reported=None, n_eff=None):
    """:func:`bayescal.core.response.pendulum.reweighted_sensitivity` of every channel
    whose period and damping are free, from the posterior's samples (``n_eff``
    of them independent); where they do not decide, the likelihood's
    information at their median (:func:`.unconstrained.information`) does."""
    from .unconstrained import information

    blocks = {b.channel_id: (sr.start, sr.start + 1)
              for b, (_, sr) in zip(model.blocks, model.slices) if b.free == "all"}
    if not blocks:
        return {}
    pr = model.priors
    with single_threaded_blas():
        return pendulum.reweighted_sensitivity(samples, blocks, pr.period_tolerance,
                                               pr.damping_tolerance, reported,
                                               information=lambda th: information(model, th),
                                               n_eff=n_eff)


def _misfit_meta(model, theta):
    """``meta.misfit_scale``: the prior and each band's variance factor at ``theta``."""
    q, k = model.band_energy(np.atleast_2d(theta))
    return misfit_scale.describe(model.misfit_shape, q[0], k)
