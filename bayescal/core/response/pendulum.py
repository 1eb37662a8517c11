"""The pendulum pair of a velocity sensor in the coordinates the data see,
its prior, and what the data fix.

A two-pole response with natural period T0 and damping h has the
denominator ``D(s) = s^2 + c1 s + c0`` with ``c1 = 2 h w0`` and
``c0 = w0^2`` (``w0 = 2 pi / T0``), so that ``H^-1`` is linear in
``(c0, c1)``. The sampler sees them relative to nominal,

    c0_rel = c0 / c0_nom = (T_nom / T0)^2,
    c1_rel = c1 / c1_nom = (h / h_nom) (T_nom / T0),

both 1 at the nominal response: a band well above the corner fixes
``c1``, i.e. ``damping / period = c1 / (4 pi)``, along a straight line in
these coordinates rather than along a curved ridge in (period, damping).

The prior is stated on period and damping: each log-normal around its
nominal value with a relative standard deviation, the manufacturer's
tolerance (:data:`PERIOD_TOLERANCE`, :data:`DAMPING_TOLERANCE` by default;
``--period-tolerance`` and ``--damping-tolerance`` widen it). It is carried
to ``(c0_rel, c1_rel)`` with its Jacobian, ``|d(ln T0, ln h) / d(c0_rel,
c1_rel)| = 1 / (2 c0_rel c1_rel)``.

**What the prior sets.** A parameter is *set by the prior* when

* halving or doubling the prior's width changes its posterior standard
  deviation by more than a factor :data:`WIDTH_RATIO` (the prior then
  carries about 40 % or more of what is known about it: its width, not the
  data, sets the interval; a prior centred on the truth sets a parameter
  this way without moving it), or
* doubling the prior's width moves its median by more than :data:`SHIFT_SD`
  of its standard deviation (the prior pulls it toward nominal: the data
  put it in the prior's tail).

Halving a log-normal prior's width is not used for the median: it moves the
median of every parameter whose true value lies a couple of tolerances from
nominal, however well the data fix it. Where the posterior is sampled, the
test reweights its samples to the rescaled prior (importance weights, the
ratio of the two priors; :func:`reweighted_sensitivity`): no second fit, and
no Gaussian assumption. A decision taken from the samples keeps a margin
against their Monte Carlo error: a reweighted value within
:data:`MC_MARGIN` of its Monte Carlo standard errors of its threshold does
not decide, and neither do reweighted samples that run out (their
effective number under a rescaled prior's weights below
:data:`MIN_WEIGHT_ESS` of them: the doubled prior's weights have no finite
variance once the prior carries more than two thirds of the information).
Then the rule that does not depend on the samples decides: the posterior's
Gaussian approximation about its median, the likelihood's Fisher
information plus the prior's, with the prior rescaled
(:func:`prior_sensitivity`). A model criticism's improved model (whose
samples may be a Laplace approximation's, which a doubled prior's weights
read poorly) uses that rule throughout. A parameter
the prior sets is not a measurement: it is reported as such, together with
the combination the data fix (``damping / period``) when that one is not
set by the prior.
"""
from __future__ import annotations

import math

import numpy as np

#: Default prior: relative standard deviation of the natural period.
PERIOD_TOLERANCE = 0.05
#: Default prior: relative standard deviation of the damping.
DAMPING_TOLERANCE = 0.05
#: Median shift (in standard deviations) under a doubled prior above which
#: the prior sets a parameter.
SHIFT_SD = 0.5
#: Change of the standard deviation (a factor either way) under a halved or
#: doubled prior above which the prior sets a parameter.
WIDTH_RATIO = 1.5
#: The prior's width is scaled by these factors in the test (the median's
#: shift is taken from the scales above 1 only).
PRIOR_SCALES = (0.5, 2.0)
#: Smallest effective share of the samples under a rescaled prior's weights
#: for the reweighted posterior to be trusted (:func:`reweighted_sensitivity`).
MIN_WEIGHT_ESS = 0.1
#: Monte Carlo standard errors by which a reweighted shift or width ratio
#: must clear its threshold for the samples to decide
#: (:func:`reweighted_sensitivity`); nearer, :func:`prior_sensitivity` does.
MC_MARGIN = 3.0
#: Monte Carlo variance factors of a Gaussian's estimates from ``n``
#: independent draws, in units of ``sd^2 / n``: the median, pi / 2; the half
#: distance between the 16 % and 84 % quantiles, ``(q (1 - q) - q^2) /
#: (2 phi(1)^2)`` with ``q = Phi(-1)`` (the quantiles' asymptotic
#: covariance), 0.925.
MEDIAN_VAR = np.pi / 2
_Q, _PHI = 0.5 * math.erfc(1 / math.sqrt(2)), math.exp(-0.5) / math.sqrt(2 * math.pi)
HALF_WIDTH_VAR = (_Q * (1 - _Q) - _Q ** 2) / (2 * _PHI ** 2)
#: Names of the pendulum's sampling coordinates.
NAMES = ("c0_rel", "c1_rel")


def to_physical(c0_rel, c1_rel, period_nom, damping_nom):
    """(period, damping) from the relative coefficients (arrays allowed)."""
    root = np.sqrt(c0_rel)
    return period_nom / root, damping_nom * c1_rel / root


def from_physical(period, damping, period_nom, damping_nom):
    """(c0_rel, c1_rel) of a period and damping (arrays allowed)."""
    ratio = period_nom / np.asarray(period, float)
    return ratio ** 2, np.asarray(damping, float) / damping_nom * ratio


def log_deviations(c0_rel, c1_rel):
    """``(ln T0/T_nom, ln h/h_nom)``; NaN where a coefficient is not positive."""
    with np.errstate(invalid="ignore", divide="ignore"):
        lc0 = np.log(np.where(c0_rel > 0, c0_rel, np.nan))
        lc1 = np.log(np.where(c1_rel > 0, c1_rel, np.nan))
    return -0.5 * lc0, lc1 - 0.5 * lc0


def log_prior(c0_rel, c1_rel, period_tol, damping_tol):
    """Log prior density in ``(c0_rel, c1_rel)`` (up to a constant): the
    log-normal priors on period and damping and their Jacobian; ``-inf``
    where a coefficient is not positive."""
    x, y = log_deviations(np.asarray(c0_rel, float), np.asarray(c1_rel, float))
    with np.errstate(invalid="ignore"):
        lp = -0.5 * (x / period_tol) ** 2 - 0.5 * (y / damping_tol) ** 2 + 2.0 * x - (y - x)
    return np.where(np.isfinite(lp), lp, -np.inf)


def prior_precision(c0_rel, c1_rel, period_tol, damping_tol):
    """The prior's Gauss-Newton precision (2 x 2) in ``(c0_rel, c1_rel)`` at a
    point, and the gradient (2, 2) of ``(ln T0, ln h)`` there (rows)."""
    jac = np.array([[-0.5 / c0_rel, 0.0], [-0.5 / c0_rel, 1.0 / c1_rel]])
    return jac.T @ np.diag([period_tol ** -2, damping_tol ** -2]) @ jac, jac


def prior_residual(c0_rel, c1_rel, period_tol, damping_tol):
    """Least squares' rows for the prior: ``(r, J)`` with ``r`` (2,) whose
    squared norm is the log-normal priors' ``-log p`` less their Jacobian,
    ``(ln T0/T_nom / period_tol, ln h/h_nom / damping_tol) / sqrt 2``, and
    ``J`` (2, 2) its derivative in ``(c0_rel, c1_rel)``."""
    c0, c1 = max(float(c0_rel), 1e-12), max(float(c1_rel), 1e-12)
    x, y = log_deviations(c0, c1)
    scale = np.array([period_tol, damping_tol]) * np.sqrt(2.0)
    return np.array([x, y]) / scale, prior_precision(c0, c1, period_tol, damping_tol)[1] / \
        scale[:, None]


def prior_sensitivity(fisher, theta, blocks, period_tol, damping_tol, extra_var=None):
    """Does the prior set period, damping or damping/period?

    Parameters
    ----------
    fisher : (n, n) the likelihood's information at ``theta`` (every
        parameter of the model).
    theta : (n,) the posterior's median in model coordinates.
    blocks : ``{channel id: (i0, i1)}`` indices of ``c0_rel`` and ``c1_rel``.
    extra_var : optional ``{channel id: (3,)}`` variances (log units) added
        to those of ``ln T0``, ``ln h`` and ``ln(h / T0)`` whatever the prior:
        a spread the reported values carry beyond the model's (the
        reference's metadata tolerance drawn into them).

    Returns ``{channel id: {name: {"set_by_prior": bool, "shift_sd": float,
    "width_ratio": float}}}`` for ``period_s``, ``damping`` and
    ``damping_over_period``: the shift of the median (in its standard
    deviations) under the doubled prior and the largest change of the
    standard deviation (a factor >= 1) under the halved and doubled prior.
    """
    theta = np.asarray(theta, float)
    n = theta.size
    q, grads, devs = _prior_terms(theta, blocks, period_tol, damping_tol)
    cov1 = np.linalg.pinv(fisher + q, hermitian=True)
    out = {cid: {name: {"set_by_prior": False, "shift_sd": 0.0, "width_ratio": 1.0}
                 for name in ("period_s", "damping", "damping_over_period")} for cid in blocks}
    for s in PRIOR_SCALES:
        # the log prior changes by -(1/s^2 - 1) (x^2/2 sx^2 + y^2/2 sy^2): one Newton step
        grad = np.zeros(n)
        for idx, jac, dev in devs.values():
            grad[idx] += -(1.0 / s ** 2 - 1.0) * (jac.T @ dev)
        cov_s = np.linalg.pinv(fisher + q / s ** 2, hermitian=True)
        step = cov_s @ grad
        for cid, g in grads.items():
            more = np.zeros(3) if extra_var is None or cid not in extra_var \
                else np.asarray(extra_var[cid], float)
            sd1 = np.sqrt(np.maximum(np.einsum("ki,ij,kj->k", g, cov1, g) + more, 1e-300))
            sds = np.sqrt(np.maximum(np.einsum("ki,ij,kj->k", g, cov_s, g) + more, 1e-300))
            shift = np.abs(g @ step) / sd1
            ratio = np.maximum(sds / sd1, sd1 / sds)
            for k, name in enumerate(("period_s", "damping", "damping_over_period")):
                e = out[cid][name]
                if s > 1:
                    e["shift_sd"] = max(e["shift_sd"], float(shift[k]))
                e["width_ratio"] = max(e["width_ratio"], float(ratio[k]))
    for entries in out.values():
        for e in entries.values():
            e["set_by_prior"] = bool(e["shift_sd"] > SHIFT_SD or e["width_ratio"] > WIDTH_RATIO)
    return out


def _prior_terms(theta, blocks, period_tol, damping_tol):
    """The prior's pieces at ``theta``: ``(q, grads, devs)``, its precision
    (n, n), per channel the gradients (3, n) of ln T0, ln h and ln(h / T0),
    and per channel ``(indices, jacobian, scaled log deviations)``."""
    n = theta.size
    q = np.zeros((n, n))
    grads = {}
    devs = {}
    for cid, (i0, i1) in blocks.items():
        c0, c1 = theta[i0], theta[i1]
        prec, jac = prior_precision(c0, c1, period_tol, damping_tol)
        idx = np.array([i0, i1])
        q[np.ix_(idx, idx)] += prec
        # rows: ln T0, ln h, ln(h / T0) = ln c1_rel + const
        g = np.zeros((3, n))
        g[0, idx], g[1, idx] = jac[0], jac[1]
        g[2, i1] = 1.0 / c1
        grads[cid] = g
        x, y = log_deviations(c0, c1)
        devs[cid] = (idx, jac, np.array([x / period_tol ** 2, y / damping_tol ** 2]))
    return q, grads, devs


def _weighted_quantiles(x, w, q):
    order = np.argsort(x)
    cw = np.cumsum(w[order])
    return np.interp(np.asarray(q) * cw[-1], cw, x[order])


def reweighted_sensitivity(samples, blocks, period_tol, damping_tol, reported=None,
                           information=None, n_eff=None):
    """:func:`prior_sensitivity`'s answer from posterior samples: each
    channel's samples reweighted to its prior with the width halved and
    doubled (weights ``p_s / p_1 = exp(-(1/s^2 - 1) (x^2 / 2 sT^2 + y^2 /
    2 sh^2))``, ``x``, ``y`` the log deviations from nominal; the Jacobian
    does not depend on the width), and the same rule on the weighted
    medians and standard deviations (the sd as the half width of the
    central 68 %).

    The samples decide only with a margin: a shift or width ratio within
    :data:`MC_MARGIN` Monte Carlo standard errors of its threshold (the
    errors of a Gaussian's median and 68 % half width from ``n_eff`` draws,
    times the weights' effective share of them under the rescaled prior),
    or a rescaled prior whose weights leave fewer than
    :data:`MIN_WEIGHT_ESS` of the samples effective (``beyond_samples``),
    is decided by :func:`prior_sensitivity` at the samples' median instead
    (``rule`` says which decided; the samples' own values are then under
    ``sampled``).

    ``samples`` (N, n) in model coordinates; ``blocks`` ``{channel id: (i0,
    i1)}`` the columns of ``c0_rel`` and ``c1_rel``. ``information``: the
    likelihood's Fisher information (n, n), or a callable giving it at a
    point (called at most once, at the samples' median); None: each
    channel's from the samples' covariance (the posterior's precision less
    the prior's). ``n_eff``: the samples' effective number of independent
    draws (a chain's smallest effective sample size); None: ``N``.
    ``reported`` (optional)
    ``{channel id: (N, 2)}`` the period and damping the result reports for
    the same samples, row for row, when they are not the model's own (the
    reference's metadata tolerance drawn into them,
    :mod:`bayescal.core.response.reference_tolerance`): the weights still
    come from the prior on the model's coordinates, and the rule judges the
    reported values, as refits with the prior rescaled would (the Fisher
    rule with their extra spread added)."""
    samples = np.asarray(samples, float)
    n_draws = float(n_eff) if n_eff is not None else float(len(samples))
    out, undecided, extra = {}, {}, {}
    for cid, (i0, i1) in blocks.items():
        x, y, quad, more = _judged_values(
            samples[:, i0], samples[:, i1], period_tol, damping_tol,
            reported[cid] if reported is not None and cid in reported else None)
        if more is not None:
            extra[cid] = more
        n1 = n_draws * x.size / len(samples)
        entries, beyond = _reweighted(x, y, quad, n1)
        names = _decide(entries, beyond)
        if names:
            undecided[cid] = names
        out[cid] = entries
    if undecided:
        _decide_by_curvature(out, undecided, samples, blocks, period_tol, damping_tol,
                             information, extra)
    return out


def _judged_values(c0, c1, period_tol, damping_tol, reported):
    """A channel's log deviations from nominal that the rule judges and the
    prior's quadratic form: ``(x, y, quad, extra)``, the model's own, or
    the ``reported`` (N, 2) period and damping's where at least half are
    numbers, then with ``extra`` their variances beyond the model's (else
    None)."""
    x, y = log_deviations(c0, c1)
    quad = 0.5 * (x / period_tol) ** 2 + 0.5 * (y / damping_tol) ** 2
    own = {"period_s": x, "damping": y, "damping_over_period": y - x}
    extra = None
    if reported is not None:
        with np.errstate(invalid="ignore", divide="ignore"):
            rx, ry = np.log(np.asarray(reported, float)[:, :2]).T
        ok = np.isfinite(rx) & np.isfinite(ry) & np.isfinite(quad)
        if ok.mean() >= 0.5:        # judged on the rows reported as numbers
            x, y, quad = rx[ok], ry[ok], quad[ok]
            extra = [max(_half_width(r) ** 2 - _half_width(v[ok]) ** 2, 0.0)
                     for r, v in zip((x, y, y - x), own.values())]
        # else: too few reported values to judge; the model's own are
    return x, y, quad, extra


def _reweighted(x, y, quad, n1):
    """The entries of one channel from its samples reweighted to the prior
    halved and doubled (``n1`` effective draws), and whether a rescaled
    prior's weights left too few samples effective."""
    values = {"period_s": x, "damping": y, "damping_over_period": y - x}
    entries = {name: {"set_by_prior": False, "shift_sd": 0.0, "width_ratio": 1.0,
                      "mc_se": {"shift_sd": 0.0, "width_ratio": 0.0}} for name in values}
    ones = np.ones(x.size)
    base = {name: _weighted_quantiles(v, ones, (0.16, 0.5, 0.84)) for name, v in values.items()}
    beyond = False
    for s in PRIOR_SCALES:
        logw = -(1.0 / s ** 2 - 1.0) * quad
        w = np.exp(logw - np.max(logw))
        share = w.sum() ** 2 / np.sum(w * w) / x.size
        if not share >= MIN_WEIGHT_ESS:
            beyond = True
            continue
        ns = max(n1 * share, 1.0)
        for name, v in values.items():
            e = entries[name]
            lo1, med1, hi1 = base[name]
            lo, med, hi = _weighted_quantiles(v, w, (0.16, 0.5, 0.84))
            sd1, sds = 0.5 * (hi1 - lo1), 0.5 * (hi - lo)
            ratio = float(max(sds / sd1, sd1 / sds))
            if ratio > e["width_ratio"]:
                e["width_ratio"] = ratio
                e["mc_se"]["width_ratio"] = ratio * math.sqrt(HALF_WIDTH_VAR * (1 / ns + 1 / n1))
            if s > 1:
                shift = float(abs(med - med1) / sd1)
                if shift >= e["shift_sd"]:
                    e["shift_sd"] = shift
                    e["mc_se"]["shift_sd"] = math.sqrt(
                        MEDIAN_VAR * ((sds / sd1) ** 2 / ns + 1 / n1))
    return entries, beyond


def _decide(entries, beyond):
    """Decide each entry whose shift and width ratio clear the thresholds
    by :data:`MC_MARGIN` Monte Carlo errors; returns the names left undecided."""
    undecided = []
    for name, e in entries.items():
        if beyond:
            e["beyond_samples"] = True
            undecided.append(name)
            continue
        se = e["mc_se"]
        above = (e["shift_sd"] - MC_MARGIN * se["shift_sd"] > SHIFT_SD
                 or e["width_ratio"] - MC_MARGIN * se["width_ratio"] > WIDTH_RATIO)
        below = (e["shift_sd"] + MC_MARGIN * se["shift_sd"] <= SHIFT_SD
                 and e["width_ratio"] + MC_MARGIN * se["width_ratio"] <= WIDTH_RATIO)
        e["set_by_prior"], e["rule"] = bool(above), "reweighted samples"
        if not (above or below):
            undecided.append(name)
    return undecided


def _decide_by_curvature(out, undecided, samples, blocks, period_tol, damping_tol,
                         information, extra):
    """Decide the ``undecided`` entries of ``out`` by :func:`_curvature_rule`,
    keeping the samples' own values under ``sampled``."""
    curv = _curvature_rule(samples, {c: blocks[c] for c in undecided}, period_tol,
                           damping_tol, information, extra)
    for cid, names in undecided.items():
        for name in names:
            e = out[cid][name]
            sampled = {k: e.pop(k) for k in ("shift_sd", "width_ratio", "mc_se")}
            c = curv[cid][name]
            e.update(c, rule="likelihood curvature (Fisher)")
            if not e.get("beyond_samples"):
                e["sampled"] = sampled


def _half_width(v):
    lo, hi = np.quantile(v, (0.16, 0.84))
    return 0.5 * (hi - lo)


def _curvature_rule(samples, blocks, period_tol, damping_tol, information, extra):
    """:func:`prior_sensitivity` at the samples' median: with the
    likelihood's ``information`` (an array or a callable of the point), or
    without it each channel's from the samples' covariance in its two
    coordinates (the posterior precision less the prior's, negative
    directions clipped to zero)."""
    med = np.median(samples, axis=0)
    if information is not None:
        fisher = information(med) if callable(information) else np.asarray(information, float)
        return prior_sensitivity(fisher, med, blocks, period_tol, damping_tol, extra)
    out = {}
    for cid, (i0, i1) in blocks.items():
        idx = [i0, i1]
        cov = np.atleast_2d(np.cov(samples[:, idx], rowvar=False))
        prec = np.linalg.pinv(cov, hermitian=True) - prior_precision(
            med[i0], med[i1], period_tol, damping_tol)[0]
        vals, vecs = np.linalg.eigh(0.5 * (prec + prec.T))
        fisher = (vecs * np.maximum(vals, 0.0)) @ vecs.T
        out[cid] = prior_sensitivity(fisher, med[idx], {cid: (0, 1)}, period_tol, damping_tol,
                                     {cid: extra[cid]} if cid in extra else None)[cid]
    return out


def damping_over_period(period, damping):
    """The combination a band above the corner fixes, in 1/s."""
    return np.asarray(damping, float) / np.asarray(period, float)


def set_by_prior_entries(sensitivity):
    """``meta["set_by_prior"]`` entries (``"<channel>:period_s"``,
    ``"<channel>:damping"``, ``"<channel>:damping_over_period"``) for what
    :func:`prior_sensitivity` finds the prior sets."""
    out = {}
    for cid, entries in sensitivity.items():
        fixed = not entries["damping_over_period"]["set_by_prior"]
        for name, e in entries.items():
            if not e["set_by_prior"]:
                continue
            if name == "damping" and fixed:
                action = ("not measured; the corrected StationXML writes it from the measured "
                          "damping/period")
            else:
                action = "not measured; the corrected StationXML keeps its nominal value"
            if e["width_ratio"] > WIDTH_RATIO:
                why = (f"the prior's width sets its interval: halving or doubling the prior "
                       f"changes its sd by a factor {e['width_ratio']:.2f} (limit {WIDTH_RATIO:g})")
            else:
                why = (f"the prior pulls it toward nominal: doubling the prior's width moves its "
                       f"median by {e['shift_sd']:.2f} of its sd (limit {SHIFT_SD:g}); the data "
                       "put it in the prior's tail, and a wider tolerance lets them decide")
            if e.get("rule", "").startswith("likelihood curvature"):
                why += (" (from the likelihood's curvature at the median: the posterior's "
                        "samples reweighted to the rescaled prior "
                        + ("run out)" if e.get("beyond_samples") else
                           "are within their Monte Carlo error of the limit)"))
            out[f"{cid}:{name}"] = {"action": action, "reason": why}
    return out
