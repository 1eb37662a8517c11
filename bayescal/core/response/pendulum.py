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
no Gaussian assumption; where the reweighted posterior would reach beyond
the samples (their effective number under the weights below
:data:`MIN_WEIGHT_ESS` of them) the prior's width decides by that fact
alone. A model criticism's improved model (whose samples may be a Laplace
approximation's, which a doubled prior's weights read poorly) uses the
posterior's Gaussian approximation about its median: the likelihood's
Fisher information plus the prior's, with the prior rescaled
(:func:`prior_sensitivity`). A parameter
the prior sets is not a measurement: it is reported as such, together with
the combination the data fix (``damping / period``) when that one is not
set by the prior.
"""
from __future__ import annotations

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


def prior_sensitivity(fisher, theta, blocks, period_tol, damping_tol):
    """Does the prior set period, damping or damping/period?

    Parameters
    ----------
    fisher : (n, n) the likelihood's information at ``theta`` (every
        parameter of the model).
    theta : (n,) the posterior's median in model coordinates.
    blocks : ``{channel id: (i0, i1)}`` indices of ``c0_rel`` and ``c1_rel``.

    Returns ``{channel id: {name: {"set_by_prior": bool, "shift_sd": float,
    "width_ratio": float}}}`` for ``period_s``, ``damping`` and
    ``damping_over_period``: the shift of the median (in its standard
    deviations) under the doubled prior and the largest change of the
    standard deviation (a factor >= 1) under the halved and doubled prior.
    """
    theta = np.asarray(theta, float)
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
            sd1 = np.sqrt(np.maximum(np.einsum("ki,ij,kj->k", g, cov1, g), 1e-300))
            sds = np.sqrt(np.maximum(np.einsum("ki,ij,kj->k", g, cov_s, g), 1e-300))
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


def _weighted_quantiles(x, w, q):
    order = np.argsort(x)
    cw = np.cumsum(w[order])
    return np.interp(np.asarray(q) * cw[-1], cw, x[order])


def reweighted_sensitivity(samples, blocks, period_tol, damping_tol, reported=None):
    """:func:`prior_sensitivity`'s answer from posterior samples: each
    channel's samples reweighted to its prior with the width halved and
    doubled (weights ``p_s / p_1 = exp(-(1/s^2 - 1) (x^2 / 2 sT^2 + y^2 /
    2 sh^2))``, ``x``, ``y`` the log deviations from nominal; the Jacobian
    does not depend on the width), and the same rule on the weighted
    medians and standard deviations (the sd as the half width of the
    central 68 %). A rescaled prior whose weights leave fewer than
    :data:`MIN_WEIGHT_ESS` of the samples effective sets the values.

    ``samples`` (N, n) in model coordinates; ``blocks`` ``{channel id: (i0,
    i1)}`` the columns of ``c0_rel`` and ``c1_rel``. ``reported`` (optional)
    ``{channel id: (N, 2)}`` the period and damping the result reports for
    the same samples, row for row, when they are not the model's own (the
    reference's metadata tolerance drawn into them,
    :mod:`bayescal.core.response.reference_tolerance`): the weights still
    come from the prior on the model's coordinates, and the rule judges the
    reported values, as refits with the prior rescaled would."""
    samples = np.asarray(samples, float)
    out = {}
    for cid, (i0, i1) in blocks.items():
        x, y = log_deviations(samples[:, i0], samples[:, i1])
        quad = 0.5 * (x / period_tol) ** 2 + 0.5 * (y / damping_tol) ** 2
        if reported is not None and cid in reported:
            with np.errstate(invalid="ignore", divide="ignore"):
                rx, ry = np.log(np.asarray(reported[cid], float)[:, :2]).T
            ok = np.isfinite(rx) & np.isfinite(ry) & np.isfinite(quad)
            if ok.mean() >= 0.5:        # judged on the rows reported as numbers
                x, y, quad = rx[ok], ry[ok], quad[ok]
            # else: too few reported values to judge; the model's own are
        n_rows = x.size
        values = {"period_s": x, "damping": y, "damping_over_period": y - x}
        entries = {name: {"set_by_prior": False, "shift_sd": 0.0, "width_ratio": 1.0}
                   for name in values}
        ones = np.ones(n_rows)
        base = {name: _weighted_quantiles(v, ones, (0.16, 0.5, 0.84)) for name, v in values.items()}
        for s in PRIOR_SCALES:
            logw = -(1.0 / s ** 2 - 1.0) * quad
            w = np.exp(logw - np.max(logw))
            ess = w.sum() ** 2 / np.sum(w * w) / n_rows
            for name, v in values.items():
                e = entries[name]
                if not ess >= MIN_WEIGHT_ESS:
                    e["beyond_samples"] = True
                    continue
                lo1, med1, hi1 = base[name]
                lo, med, hi = _weighted_quantiles(v, w, (0.16, 0.5, 0.84))
                sd1, sds = 0.5 * (hi1 - lo1), 0.5 * (hi - lo)
                e["width_ratio"] = max(e["width_ratio"], float(max(sds / sd1, sd1 / sds)))
                if s > 1:
                    e["shift_sd"] = max(e["shift_sd"], float(abs(med - med1) / sd1))
        for e in entries.values():
            e["set_by_prior"] = bool(e["shift_sd"] > SHIFT_SD or e["width_ratio"] > WIDTH_RATIO
                                     or e.get("beyond_samples", False))
        out[cid] = entries
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
            if e.get("beyond_samples"):
                why = ("the prior's width sets its interval: with the prior halved or doubled "
                       "the posterior would reach beyond what its samples cover")
            elif e["width_ratio"] > WIDTH_RATIO:
                why = (f"the prior's width sets its interval: halving or doubling the prior "
                       f"changes its sd by a factor {e['width_ratio']:.2f} (limit {WIDTH_RATIO:g})")
            else:
                why = (f"the prior pulls it toward nominal: doubling the prior's width moves its "
                       f"median by {e['shift_sd']:.2f} of its sd (limit {SHIFT_SD:g}); the data "
                       "put it in the prior's tail, and a wider tolerance lets them decide")
            out[f"{cid}:{name}"] = {"action": action, "reason": why}
    return out
