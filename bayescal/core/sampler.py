"""From spectra to posterior samples: global closed-form start, least-squares
refinement, sampling run until converged (emcee's DE moves, or, for a pair
fit, a DE burn-in followed by independence Metropolis-Hastings with a frozen
t proposal: :mod:`bayescal.core.independence`).

Convergence rule (all must hold, checked every chunk of steps):

* at least ``n_tau`` (50) integrated autocorrelation times of kept chain for
  the slowest parameter (tau as :func:`emcee.autocorr.integrated_time`,
  averaged over walkers);
* at least ``min_ess`` (1000) effective samples for every parameter;
* split R-hat below ``rhat_max`` (1.01), computed between the two halves of
  the kept chain. Walkers of one ensemble are not independent, so R-hat across
  walkers would not be valid; each half counts its effective (not raw) draws.
"""
from __future__ import annotations

import warnings
from dataclasses import dataclass

import numpy as np
from scipy.optimize import least_squares

from . import misfit_scale, refnoise
from .ensemble import Ensemble, integrated_time
from .geometry import Circle, Fixed, Sphere
from .eiv import EIVModel
from .likelihood import ChannelBlock, Model, Priors
from .unconstrained import prior_bounds as _bounds

#: A SUT channel is fitted against a two- or one-channel reference only when
#: its nominal axis lies within this angle (degrees) of the reference's span.
SPAN_TOLERANCE_DEG = 30.0


class FitError(RuntimeError):
    """The fit cannot proceed (nothing estimable, optimizer failure...)."""


def closed_form_transfer(spectra):
    """Global start: the real 3x3 (n_u x n_r) transfer ``T = Re(S_ur) Re(S_rr)^-1``
    from all bands together. Independent of any nominal orientation, so a
    sensor turned round, or with reversed or swapped channels, is found."""
    s = spectra.band_sums().sum(axis=0)
    nu = spectra.n_u
    return np.real(s[:nu, nu:]) @ np.linalg.inv(np.real(s[nu:, nu:]))


def _span_basis(ref_vectors):
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


def build_model(spectra, ref_vectors, sut_nominal_vectors, families, free="none",
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
        see :mod:`bayescal.core.refnoise`); None: "quiet"; "fixed" with
        ``known_noise`` (B, n_r): the reference's self-noise given.
    """
    ref_vectors = np.asarray(ref_vectors, float)
    basis, _ = _span_basis(ref_vectors)
    rank = basis.shape[0]
    t_hat = closed_form_transfer(spectra)
    v_hat = t_hat @ ref_vectors                                   # (nu, 3)
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
    if free != "none" and any(families[i] is None for i in fitted):
        raise FitError("gain fitting needs a response with a gain on every fitted channel")
    if free == "all" and any(not np.isfinite(families[i].period_s) for i in fitted):
        raise FitError("fitting period and damping (--fit-response all) needs a poles-and-zeros "
                       "first stage with a pendulum pair on every fitted channel ('flat' has "
                       "none: use the default, which fits each channel's gain)")
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
            theta0.extend([np.log(fam.period_s), fam.damping, np.log(fam.gain * norm)])
        blocks.append(ChannelBlock(channel_id=str(sub.sut_ids[len(blocks)]) if sub.sut_ids
                                   else str(i), manifold=manifold, family=fam, free=free))
    if ref_noise in (None, "quiet"):
        model = Model(sub, ref_vectors, blocks, priors)
    else:
        model = EIVModel(sub, ref_vectors, blocks, priors, ref_noise=ref_noise,
                         known_noise=known_noise)
    return Setup(model=model, theta0=np.asarray(theta0, float), fitted=fitted,
                 not_estimable=skipped)


def least_squares_fit(model, theta0, iterations=2, jac=None):
    """Refine ``theta0`` by :func:`scipy.optimize.least_squares` on the
    whitened residual, re-estimating the noise model after each pass.
    ``jac``: scipy's ``"2-point"``, a callable such as
    :func:`bayescal.core.jacobian.forward_jacobian`'s, or None: ``"2-point"``
    for the base model (whose numbers are fixed) and the one-call forward
    Jacobian for the errors-in-variables model (its residual costs several
    times the base model's; the columns agree to rounding).

    Returns ``(theta, covariance)``; the covariance is the inverse Fisher
    information ``(2 J^T J)^-1`` (``-log L`` is the squared residual norm).
    """
    if jac is None:
        from .jacobian import forward_jacobian
        jac = forward_jacobian(model) if isinstance(model, EIVModel) else "2-point"
    lo, hi = _bounds(model)
    theta = np.clip(np.asarray(theta0, float), lo + 1e-9, hi - 1e-9)
    model.estimate_noise(theta)
    tol = dict(xtol=1e-12, ftol=1e-12, gtol=1e-12)
    for _ in range(iterations):
        fac = model.noise.cholesky()
        # Levenberg-Marquardt: the trust-region method stalls when the start
        # is exactly zero in the tangent-plane coordinates (its first trust
        # radius is |x0| = 0); fall back to it only when LM leaves the box.
        # LM's trial steps are unbounded: one far outside the box overflows
        # the response (exp of a large log-gain); its residual is rejected by
        # LM and the box check below, so those warnings are noise
        with np.errstate(over="ignore", invalid="ignore", divide="ignore"):
            res = least_squares(model.whitened_residual, theta, jac=jac, args=(fac,),
                                method="lm", **tol)
        if np.any(res.x < lo) or np.any(res.x > hi):
            res = least_squares(model.whitened_residual, np.clip(res.x, lo + 1e-9, hi - 1e-9),
                                jac=jac, args=(fac,), bounds=(lo, hi), method="trf", **tol)
        if not np.isfinite(res.x).all():
            raise FitError("least squares left the finite parameter range (a non-finite "
                           "residual); check the responses and the band")
        theta = res.x
        model.estimate_noise(theta)
    fac = model.noise.cholesky()
    jac = least_squares(model.whitened_residual, theta, jac=jac, args=(fac,), method="lm",
                        max_nfev=1).jac
    fisher = 2.0 * jac.T @ jac
    try:
        cov = np.linalg.inv(fisher)
    except np.linalg.LinAlgError as exc:
        raise FitError("the least-squares point is degenerate (singular information)") from exc
    return theta, 0.5 * (cov + cov.T)


def split_rhat(chain, ess):
    """Split R-hat between the two halves of ``chain`` (n, W, ndim), each half
    flattened over walkers and counted as ``ess / 2`` effective draws."""
    n = chain.shape[0] // 2
    a = chain[:n].reshape(-1, chain.shape[2])
    b = chain[n:2 * n].reshape(-1, chain.shape[2])
    m_eff = np.maximum(ess / 2.0, 2.0)
    w = 0.5 * (a.var(axis=0, ddof=1) + b.var(axis=0, ddof=1))
    between = m_eff * (a.mean(axis=0) - b.mean(axis=0)) ** 2 / 2.0
    var_plus = (m_eff - 1) / m_eff * w + between / m_eff
    return np.sqrt(var_plus / w)


@dataclass
class Chain:
    """Kept (post burn-in, thinned) samples and convergence figures."""

    samples: np.ndarray       # (N, ndim)
    log_prob: np.ndarray      # (N,)
    tau: np.ndarray           # (ndim,)
    ess: np.ndarray           # (ndim,)
    rhat: np.ndarray          # (ndim,)
    acceptance: float
    n_steps: int
    n_walkers: int
    burn: int
    converged: bool
    trace: np.ndarray         # (steps, W, ndim), thinned for plots


def sample(model, theta_start, cov, seed=0, n_walkers=None, min_ess=1000, n_tau=50,
           rhat_max=1.01, max_steps=200_000, progress=True, move="de"):
    """Run the sampler from around ``theta_start`` until the convergence rule holds.

    Walkers start from a Gaussian with covariance ``cov`` (the least-squares
    Laplace approximation) around the least-squares point. ``move="de"``:
    emcee's mixture of differential-evolution moves throughout.
    ``move="independence"``: :data:`DE_BURN` DE steps find the posterior's
    scale, then each walker runs independence Metropolis-Hastings with a
    multivariate-t proposal fitted to those draws, refitted once after
    :data:`ADAPT` steps and frozen for the kept chain
    (:mod:`bayescal.core.independence`; about 20 times fewer autocorrelation
    steps on these near-Gaussian posteriors). The draws made while fitting the
    proposal count as burn-in; if the proposal accepts less than
    :data:`MIN_ACCEPTANCE` (a posterior far from Gaussian), the DE moves
    carry on instead. The convergence rule is the same either way. Seeded
    and reproducible.
    """
    ndim = model.ndim
    n_walkers = n_walkers or max(32, 4 * ndim)
    n_walkers += n_walkers % 2
    rng = np.random.default_rng(seed)
    p0 = rng.multivariate_normal(theta_start, cov, size=n_walkers)
    for _ in range(100):
        bad = ~np.isfinite(model.log_prob(p0))
        if not bad.any():
            break
        p0[bad] = rng.multivariate_normal(theta_start, 0.01 * cov, size=int(bad.sum()))
    # emcee's DEMove (0.8) / DESnookerMove (0.2) mixture, step for step
    # (bayescal.core.ensemble: the same chain as emcee.EnsembleSampler)
    sampler = Ensemble(model.log_prob, p0, np.random.RandomState(seed).get_state())
    chunk, min_burn, min_chunk = 1000, 100, 200
    bar = _progress(progress, chunk, n_tau, min_ess, rhat_max)
    pre = np.empty((0, n_walkers, ndim))
    if move == "independence":
        frozen = _frozen_proposal(model, sampler, seed, bar)
        if frozen is not None:
            pre, sampler = frozen
            chunk, min_burn, min_chunk = 150, 10, 50
    elif move != "de":
        raise ValueError(f"unknown move {move!r}")
    # (a DE fallback keeps its burn-in steps in its own chain)
    offset, steps, converged = pre.shape[0], sampler.iteration, False
    while True:
        sampler.run(chunk, on_step=bar.step)
        steps += chunk
        full = sampler.get_chain()
        tau_all = integrated_time(full[steps // 2:])
        burn = int(min(steps // 2, max(min_burn, 5 * np.max(tau_all))))
        kept = full[burn:]
        tau = integrated_time(kept)
        ess = kept.shape[0] * n_walkers / tau
        rhat = split_rhat(kept, ess)
        need = max(n_tau * tau.max() + burn, burn + (steps - burn) * min_ess / ess.min())
        if kept.shape[0] >= n_tau * tau.max() and ess.min() >= min_ess and rhat.max() < rhat_max:
            converged = True
            bar.goal(offset + steps, kept.shape[0] / tau.max(), ess.min(), rhat.max())
            break
        chunk = int(min(max(min_chunk, 1.1 * need - steps), max_steps - steps))
        bar.goal(offset + steps + chunk, kept.shape[0] / tau.max(), ess.min(), rhat.max())
        if steps >= max_steps:
            warnings.warn(f"sampler stopped at {steps} steps without meeting the convergence rule "
                          f"(tau {tau.max():.0f}, ESS {ess.min():.0f}, R-hat {rhat.max():.3f})")
            break
    bar.close()
    thin = max(1, int(tau.min() / 4))
    kept_lp = sampler.get_chain(discard=burn, thin=thin, log_prob=True)
    full = np.concatenate([pre, full]) if offset else full
    return Chain(samples=sampler.get_chain(discard=burn, thin=thin, flat=True),
                 log_prob=kept_lp.reshape(-1), tau=tau, ess=ess, rhat=rhat,
                 acceptance=float(np.mean(sampler.acceptance_fraction)),
                 n_steps=offset + steps, n_walkers=n_walkers, burn=offset + burn,
                 converged=converged, trace=full[:: max(1, (offset + steps) // 1000)])


#: ``move="independence"``: DE steps before the first proposal is fitted (from
#: their second half), independence steps before it is refitted, and the
#: acceptance below which the DE moves carry on instead.
DE_BURN, ADAPT, MIN_ACCEPTANCE = 100, 50, 0.2


def _frozen_proposal(model, ensemble, seed, bar):
    """DE burn-in, then one adaptation round of the t proposal; returns
    (burn-in chain, walkers with the frozen proposal), or None (the DE
    ensemble, advanced by the burn-in, carries on) when the proposal cannot
    be fitted or accepts too rarely."""
    from .independence import IndependenceWalkers, TProposal
    ensemble.run(DE_BURN, on_step=bar.step)
    rng = np.random.default_rng([seed, 16])
    try:
        walk = IndependenceWalkers(model.log_prob, ensemble.coords, ensemble.log_prob,
                                   TProposal.fit(ensemble.get_chain(discard=DE_BURN // 2,
                                                                    flat=True)), rng)
        walk.run(ADAPT, on_step=bar.step)
        if np.mean(walk.acceptance_fraction) < MIN_ACCEPTANCE:
            return None
        final = IndependenceWalkers(model.log_prob, walk.coords, walk.log_prob,
                                    TProposal.fit(walk.get_chain(flat=True)), rng)
    except np.linalg.LinAlgError:   # a degenerate spread: no proposal
        return None
    return np.concatenate([ensemble.get_chain(), walk.get_chain()]), final


def single_threaded_blas():
    """Context limiting BLAS to one thread. The likelihood's products are
    small (walkers x nodes x bands): threaded BLAS only adds latency, and on a
    busy machine its threads wait on each other (measured: 18 ms against
    0.12 ms per call on 2 loaded cores)."""
    from threadpoolctl import threadpool_limits
    return threadpool_limits(limits=1, user_api="blas")


class _NoBar:
    step = None

    def goal(self, *args):
        pass

    def close(self):
        pass


class _GoalBar:
    """Progress toward the convergence rule: the bar's total is the current
    estimate of the steps the rule needs (re-estimated at every check, so
    the time left is tqdm's estimate toward it), the postfix each target:
    kept chain in autocorrelation times, smallest ESS and largest R-hat
    against their goals."""

    def __init__(self, first, n_tau, min_ess, rhat_max):
        from tqdm.auto import tqdm
        self.goals = (n_tau, min_ess, rhat_max)
        self.bar = tqdm(total=first, unit="step", desc="sampling to convergence", leave=False,
                        bar_format="{desc}: {percentage:3.0f}%|{bar}| {n}/{total} steps "
                                   "[{elapsed}<{remaining}]{postfix}")
        self.bar.set_postfix_str(f"goals: {n_tau} tau, ESS {min_ess}, R-hat < {rhat_max}")

    def step(self):
        self.bar.update(1)

    def goal(self, need_steps, kept_tau, ess, rhat):
        """New estimate of the steps needed (the next check of the rule),
        and where each target stands."""
        n_tau, min_ess, rhat_max = self.goals
        self.bar.total = max(int(np.ceil(need_steps)), self.bar.n)
        self.bar.set_postfix_str(f"chain {kept_tau:.0f}/{n_tau} tau, ESS {ess:.0f}/{min_ess}, "
                                 f"R-hat {rhat:.3f} (< {rhat_max})")

    def close(self):
        self.bar.close()


def _progress(enabled, first, n_tau, min_ess, rhat_max):
    return _GoalBar(first, n_tau, min_ess, rhat_max) if enabled else _NoBar()


def fit_spectra(spectra, ref_vectors, sut_nominal_vectors, families, free="none",
                priors=Priors(), seed=0, progress=True, meta=None, ref_noise=None,
                misfit_shape=None, known_noise=None, **sample_kw):
    """Whole inference from spectra: start, least squares, sampling.

    ``misfit_shape``: shape ``a`` of the per-band noise-scale prior
    (:mod:`bayescal.core.misfit_scale`); None: its default
    ``MISFIT_SHAPE``; ``inf``: the Gaussian likelihood.

    ``ref_noise``: None (the default) is
    :func:`bayescal.core.refnoise.recommended_mode` of the pair: "estimate"
    (the reference's self-noise estimated, unbiased whatever the split of
    noise) with two or more channels a side, "quiet" otherwise; the mode
    used and whether it was the default are in
    ``posterior.meta["reference_noise"]``. ``known_noise`` (B, n_r): the
    reference's self-noise given as band sums
    (:func:`bayescal.core.refnoise.band_sums_of_psd`), with ``ref_noise="fixed"``.

    Returns a :class:`bayescal.core.posterior.Posterior`; the least-squares point
    and the model are kept in ``posterior.meta["least_squares"]`` and on the
    returned object as ``posterior.model`` (not saved to disk).
    """
    from .posterior import Posterior
    from .rotation import fit_rotation, orthogonal_pair

    pair = orthogonal_pair(ref_vectors, sut_nominal_vectors) if free != "all" else None
    if pair is not None:   # one horizontal reference channel: ASL's orthogonal rotation
        # (gains held: one reference channel cannot tell the two horizontals'
        # gains from their rotation; a gain common to both does not bias it)
        if ref_noise not in (None, "quiet"):
            raise FitError(f"--ref-noise {ref_noise} is not available with a one-channel "
                           "horizontal reference (ASL's orthogonal-pair rotation, which assumes "
                           "the reference quiet)")
        return fit_rotation(spectra, ref_vectors, pair, seed=seed, meta=meta)
    chosen_by = "user"
    if ref_noise is None:       # the default: unbiased whatever the split of noise
        from .refnoise import recommended_mode
        ref_noise, chosen_by = recommended_mode(spectra.n_r, spectra.n_u), "default"
    setup = build_model(spectra, ref_vectors, sut_nominal_vectors, families, free, priors,
                        ref_noise=ref_noise, known_noise=known_noise)
    model = setup.model
    model.misfit_shape = misfit_scale.MISFIT_SHAPE if misfit_shape is None else misfit_shape
    if model.ndim == 0:
        raise FitError("nothing to estimate: against this reference the SUT channel's axis is "
                       "fixed to the reference's (one channel each), so only its response can "
                       "be estimated: do not hold it with --fit-response none")
    from .unconstrained import describe_late, full_samples, hold_unconstrained, late_flags
    with single_threaded_blas():
        theta_ls, cov = least_squares_fit(model, setup.theta0)
        # other optima (issue 13 item 4): the most probable mode is sampled
        model, theta_ls, cov, multimodal = _modes(model, theta_ls, cov, sut_nominal_vectors,
                                                  setup.fitted)
        separation = {}
        if getattr(model, "ref_noise", None) == "estimate":
            from .separation import gain_separation
            separation = gain_separation(model, theta_ls, cov)
        # parameters the data do not constrain are held at nominal (issue 13 item 5)
        target, start, cov, theta_ls, set_by_prior = hold_unconstrained(model, theta_ls, cov)
        chain = sample(target, start, cov, seed=seed, progress=progress,
                       **{"move": "independence", **sample_kw})
    full = full_samples(target, chain.samples)
    held = [j for j, n in enumerate(model.names) if n in set_by_prior]
    set_by_prior.update(describe_late(model, late_flags(model, full, skip=held)))
    vecs, _ = model.unpack(full)
    resp = model.response_values(full) if free != "none" else {}
    kinds = [{2: "sphere", 1: "circle", 0: "fixed"}[b.manifold.n_params] for b in model.blocks]
    meta = dict(meta or {})
    meta.update({"free_response": free, "band_hz": [float(spectra.band_edges[0]),
                                                     float(spectra.band_edges[-1])],
                 "band_edges_hz": spectra.band_edges, "n_segments": spectra.n_segments,
                 "n_segments_possible": spectra.n_segments_possible,
                 "segment_s": spectra.nperseg / spectra.fs,
                 "noise_inflation": model.noise.inflation,
                 "plugin_weights": plugin_meta(model),
                 "reference_noise": dict(refnoise.treatment_meta(model, theta_ls),
                                         chosen_by=chosen_by,
                                         **({"separation": separation} if separation else {})),
                 "misfit_scale": _misfit_meta(model, np.median(full, axis=0)),
                 "least_squares": dict(zip(model.names, theta_ls)),
                 "set_by_prior": set_by_prior, "multimodal": multimodal})
    post = Posterior(channel_ids=[b.channel_id for b in model.blocks], kinds=kinds, vectors=vecs,
                     response=resp, samples=chain.samples, names=target.names,
                     log_prob=chain.log_prob,
                     convergence={"tau": chain.tau, "ess": chain.ess, "rhat": chain.rhat,
                                  "acceptance": chain.acceptance, "n_steps": chain.n_steps,
                                  "n_walkers": chain.n_walkers, "burn": chain.burn,
                                  "converged": chain.converged},
                     meta=meta, not_estimable=setup.not_estimable, trace=chain.trace,
                     diagnostics=diagnostics(model, np.median(full, axis=0)))
    post.model = model
    post.theta_ls = theta_ls
    post.full_samples = full          # model coordinates (held parameters included)
    return post


def _modes(model, theta_ls, cov, nominal, fitted):
    """:func:`bayescal.core.modes.search`; when another mode is the most
    probable, the fit restarts there (noise model re-estimated)."""
    from .modes import search

    best, report = search(model, theta_ls, np.asarray(nominal, float)[fitted])
    if best.label.startswith("closed-form"):
        return model, theta_ls, cov, report
    theta_ls, cov = least_squares_fit(best.model, best.theta)
    return best.model, theta_ls, cov, report


def plugin_meta(model):
    """``meta.plugin_weights``: each band's likelihood weight for the plug-in
    noise model's own sampling error (:mod:`bayescal.core.plugin`)."""
    w = getattr(model.noise, "weight", None)
    return None if w is None else [round(float(v), 4) for v in w]


def _misfit_meta(model, theta):
    """``meta.misfit_scale``: the prior and each band's variance factor at ``theta``."""
    q, k = model.band_energy(np.atleast_2d(theta))
    return misfit_scale.describe(model.misfit_shape, q[0], k)


def diagnostics(model, theta):
    """Arrays a report or a model check needs, at parameter point ``theta``:
    spectra, coherences and the per-band standardised misfit."""
    sp = model.spectra
    return {"freqs": sp.freqs, "psd": sp.psd(), "multiple_coherence": sp.multiple_coherence(),
            "band_edges": sp.band_edges, "band_misfit": model.standardized_band_residuals(theta),
            "noise_inflation": model.noise.inflation,
            "sut_ids": np.array(sp.sut_ids), "ref_ids": np.array(sp.ref_ids)}
