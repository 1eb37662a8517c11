"""Several optima of one posterior: searched and weighed.

The sampler starts from one least-squares optimum and explores the mode it
starts in; a second mode the walkers never reach would be missed and the
interval reported as one narrow interval. Before sampling, least squares is
therefore also run from other starts:

* **mirrored axes**: each SUT channel's axis (and all at once) reflected
  across the plane normal to the weakest direction ``w`` of the ground
  motion seen by the reference (the smallest eigenvector of the band-averaged
  normalised ground cross-spectral matrix, within the reference's span). An
  axis ``v`` and its mirror ``v - 2 (v.w) w`` differ only along ``w``: when
  the ground hardly moves along ``w`` (a wavefield polarised in a plane, a
  single Rayleigh wave's radial-vertical plane) the two fit equally well;
  when it moves, the mirrored start falls back to the first optimum or ends
  far below it. A channel's axis enters only its own rows of the residual,
  so the start with every axis mirrored is polished only when two or more
  single mirrors ended away from the first fit: otherwise the data hold the
  axes whose mirrors came back, and it would end where a single start did
  (``ruled_out`` in the report);
* **nominal axes** from the metadata (when they differ from the optimum by
  more than ``SAME_AXIS_DEG``).

A polish runs in a chart centred on its start's axes (gnomonic: the
hemisphere around each axis). When the posterior's better fits lie beyond
the hemisphere (a mirror that reverses an axis whose polarity the data
fix), least squares runs its axis toward the chart's edge, 90 degrees from
the start, where the coordinates grow without bound and the fit stops
changing: that end point is no optimum of the posterior, whose rise goes on
past the edge. A polish is therefore stopped once one of its accepted points
inside the prior's box puts an axis at :data:`CHART_EDGE`, or ends there,
and counted as run off its chart (``off_chart`` in the report), never
listed as a mode.

Each end point is polished with the noise model of the first fit held
fixed, its log-posterior ``l_m`` and the curvature ``H_m`` of the
log-posterior measured there (finite differences, the per-band noise scale
included), and its posterior mass estimated by Laplace:
``log Z_m = l_m + g^T H^-1 g / 2 - log det(H_m / 2 pi) / 2`` (``g`` the
gradient: the least-squares point is the Gaussian's optimum, not exactly the
posterior's; the extrapolated peak is checked against the log-posterior at
the Newton point, :func:`newton_peak`). Every chart is centred on its
optimum, so these are comparable.

Two optima belong to one mode when their Mahalanobis distance (in the better
one's curvature) is below ``2 sqrt(chi2_99(ndim))``: their 99 % Laplace
ellipsoids touch, and a sampler started in one reaches the other. The
posterior is **multimodal** when a mode other than the most probable holds
at least ``MODE_MASS`` (1 %) of the mass of all modes found: a 95 %
interval drawn from one mode then misses at least a fifth again as much
mass as it claims to. For modes of equal width 1 % is a log-posterior
difference of ``log 100 = 4.6``, close to the "very strong" evidence margin
of Kass and Raftery (twice the log-likelihood ratio above 10, i.e. 5).

When multimodal, the most probable mode is sampled and every interval that
does not hold another significant mode's value is marked (``multimodal``,
with each mode's value and mass; :func:`bayescal.core.posterior.modes.mark`):
not one narrow interval but "this mode; see modes". Not searched: modes that neither start reaches (a
global search would cost a sampler run per start); independent ensembles
with R-hat between them were not used for the same reason.
"""
from __future__ import annotations

import contextlib
import copy
from dataclasses import dataclass, replace

import numpy as np
from scipy.special import gammaincinv

from ..orientation.geometry import Circle, Sphere, azimuth_dip
from ..model.jacobian import forward_jacobian as _jacobian
from ..model.jacobian import least_squares_objective
from ...errors import BudgetSpent, OffChart
from .leastsq import solve
from .unconstrained import information, pendulum_precision, prior_bounds

#: Smallest posterior mass fraction of a second mode that makes a fit multimodal.
MODE_MASS = 0.01
#: Level of the Laplace ellipsoids whose contact merges two optima into one mode.
OVERLAP_LEVEL = 0.99
#: A start whose axes all lie within this angle (degrees) of the optimum's is skipped.
SAME_AXIS_DEG = 1.0
#: The labels of the mirrored starts: one channel's (after its id), every channel's.
SINGLE = " mirrored across the weakest ground motion"
JOINT = "every axis mirrored across the weakest ground motion"
#: Gnomonic radius of a chart's edge: an axis 89.4 degrees from the chart's
#: centre (tan 89.4 deg = 100); a polish whose axis reaches it ran off its chart.
CHART_EDGE = 100.0
#: What :func:`optimum` returns for a start whose polish ran off its chart.
OFF_CHART = "ran off its chart"


@dataclass
class Optimum:
    """One least-squares end point, in a chart centred on it."""

    label: str
    model: object
    theta: np.ndarray
    log_post: float
    log_mass: float
    hessian: np.ndarray        # of -log posterior, chart coordinates
    vectors: np.ndarray        # (n_u, 3)


def weakest_ground_direction(model):
    """Unit vector (NED) of least ground motion seen by the reference, within
    its span: smallest eigenvector of ``sum_b Re(G_b) / tr(G_b)``, ``G_b`` the
    band's ground cross-spectral matrix ``V_r^+ S_rr,b V_r^+T``."""
    nu = model.spectra.n_u
    srr = model.spectra.band_sums()[:, nu:, nu:]
    g = np.einsum("ik,bkl,jl->bij", model.ref_pinv, srr, model.ref_pinv).real
    tr = np.einsum("bii->b", g)
    c = np.sum(g / np.where(tr > 0, tr, 1.0)[:, None, None], axis=0)
    _, sv, vt = np.linalg.svd(model.ref_vectors)
    span = vt[: int(np.sum(sv > 1e-6 * sv[0]))]
    ev, evec = np.linalg.eigh(span @ c @ span.T)
    w = span.T @ evec[:, 0]
    return w / np.linalg.norm(w)


def recharted(model, vectors):
    """A shallow copy of ``model`` whose sphere charts are centred on
    ``vectors`` (same parameters, names and noise model)."""
    out = copy.copy(model)
    out.blocks = [replace(b, manifold=Sphere(v0=v)) if isinstance(b.manifold, Sphere) else b
                  for b, v in zip(model.blocks, vectors)]
    return out


def theta_for(model, vectors, theta_response):
    """Parameters of ``model`` putting its axes at ``vectors`` (onto each
    circle's plane) and its response parameters as in ``theta_response``."""
    theta = np.array(theta_response, float)
    for b, (so, _), v in zip(model.blocks, model.slices, vectors):
        if b.manifold.n_params:
            theta[so] = b.manifold.params(v)
    return theta


def _polish(model, theta, factors, budget=None):
    """Least squares from ``theta`` with the noise model held fixed (within
    ``budget``: :func:`bayescal.core.fit.leastsq.solve`); None when it ran
    off its chart (:func:`off_chart`). Raises
    :class:`~bayescal.errors.BudgetSpent` when the budget ended it before it
    converged: its point is then no optimum."""
    lo, hi = prior_bounds(model)
    theta = np.clip(theta, lo + 1e-9, hi - 1e-9)
    try:
        with np.errstate(all="ignore"):     # wild steps from a poor start: the optimizer rejects them
            res = _least_squares(model, theta, factors, lo, hi, budget)
    except OffChart:                        # an accepted point at the chart's edge
        return None
    if res.status == -3:
        raise BudgetSpent(res.message)
    return None if off_chart(model, res.x) else res.x


def off_chart(model, theta):
    """Whether an axis of ``model`` at ``theta`` lies at its chart's edge
    (gnomonic radius at least :data:`CHART_EDGE`)."""
    return any(isinstance(b.manifold, Sphere) and np.hypot(*theta[so]) >= CHART_EDGE
               for b, (so, _) in zip(model.blocks, model.slices))


def _least_squares(model, theta, factors, lo, hi, budget):
    fun, jac = least_squares_objective(model, _jacobian(model))
    if callable(jac):
        jac = _EdgeWatch(model, jac, lo, hi)
    return solve(fun, theta, lo, hi, method="lm", jac=jac, args=(factors,), budget=budget)


class _EdgeWatch:
    """A least-squares ``jac`` that raises :class:`~bayescal.errors.OffChart`
    (caught by :func:`_polish`) at a point inside the box ``[lo, hi]`` with
    an axis at its chart's edge: scipy's methods evaluate the Jacobian only
    at the points they accept, so the polish has settled on running off
    its chart (:func:`off_chart`)."""

    def __init__(self, model, jac, lo, hi):
        self.model, self.jac, self.lo, self.hi = model, jac, lo, hi

    def __call__(self, theta, *args):
        inside = np.all(theta >= self.lo) and np.all(theta <= self.hi)
        if inside and off_chart(self.model, theta):
            raise OffChart("an axis at its chart's edge")
        return self.jac(theta, *args)


def curvature(log_prob, theta, step):
    """Gradient and Hessian of ``-log_prob`` at ``theta`` by central
    differences with steps ``step``, all points in one vectorised call."""
    n = theta.size
    e = np.diag(step)
    pts = [theta]
    for i in range(n):
        pts += [theta + e[i], theta - e[i]]
    pairs = [(i, j) for i in range(n) for j in range(i + 1, n)]
    for i, j in pairs:
        pts += [theta + e[i] + e[j], theta + e[i] - e[j], theta - e[i] + e[j],
                theta - e[i] - e[j]]
    f = -np.asarray(log_prob(np.array(pts)), float)
    f0, fp, fm = f[0], f[1:2 * n + 1:2], f[2:2 * n + 1:2]
    grad = (fp - fm) / (2 * step)
    hess = np.diag((fp - 2 * f0 + fm) / step ** 2)
    q = f[2 * n + 1:].reshape(-1, 4)
    for (i, j), (pp, pm, mp, mm) in zip(pairs, q):
        hess[i, j] = hess[j, i] = (pp - pm - mp + mm) / (4 * step[i] * step[j])
    return grad, hess


def optimum(model, theta, label, factors, first=None, budget=None):
    """Polish ``theta`` (within ``budget``) and describe the end point
    (chart centred on it); None when it came back within
    :func:`merge_threshold` of ``first``, :data:`OFF_CHART` when the polish
    ran off its chart."""
    if first is not None:
        theta = _polish(model, theta, factors, budget)
        if theta is None:
            return OFF_CHART
    vecs = model.unpack(theta)[0][0]
    model = recharted(model, vecs)
    theta = theta_for(model, vecs, theta)
    if first is not None:
        probe = Optimum("", model, theta, 0.0, 0.0, None, vecs)
        if distance(first, probe) < merge_threshold(model.ndim):
            return None
    lp = float(model.log_prob(theta[None])[0])
    # the posterior's curvature: the likelihood's and the pendulum prior's
    jac = _jacobian(model)
    if isinstance(jac, str):
        fisher = information(model, theta) + pendulum_precision(model)
    else:
        rows = least_squares_objective(model, jac)[1](theta, factors)
        fisher = 2.0 * rows.T @ rows
    sd = np.sqrt(np.clip(np.diag(np.linalg.pinv(fisher)), 1e-18, None))
    with np.errstate(invalid="ignore", divide="ignore", over="ignore"):
        grad, hess = curvature(model.log_prob, theta, 0.5 * sd)
        ok = np.all(np.isfinite(hess)) and np.all(np.linalg.eigvalsh(hess) > 0)
    if not ok:
        hess = fisher                   # a step crossed a prior bound: the Gaussian's
        grad = np.zeros_like(theta)
    sign, logdet = np.linalg.slogdet(hess / (2 * np.pi))
    lm = newton_peak(model.log_prob, theta, lp, grad, hess) - 0.5 * logdet
    return Optimum(label=label, model=model, theta=theta, log_post=lp, log_mass=float(lm),
                   hessian=hess, vectors=vecs)


def newton_peak(log_prob, theta, lp, grad, hess):
    """The log-posterior's peak near ``theta`` for the Laplace mass: the
    quadratic model's ``lp + g^T H^-1 g / 2`` (``g``, ``H`` of ``-log_prob``)
    only as far as ``log_prob`` at the Newton point ``theta - H^-1 g``
    confirms it, and never below ``lp``. Far from an optimum (a start that
    stalled on a poor fit, where the per-band misfit term makes the
    log-posterior flat and ``H`` small) the quadratic extrapolates hundreds
    of log units above anything the posterior reaches; unchecked, such a
    point once outweighed the real optimum and was sampled instead
    (``tests/test_modes.py``)."""
    step = np.linalg.solve(hess, grad)
    predicted = lp + 0.5 * grad @ step
    with np.errstate(all="ignore"):
        at_step = float(np.asarray(log_prob((theta - step)[None]))[0])
    if not np.isfinite(at_step):
        return lp
    return max(lp, min(predicted, at_step))


def distance(a, b):
    """Mahalanobis distance of optimum ``b`` from ``a`` in ``a``'s chart and
    curvature; infinite when ``b``'s axes are off ``a``'s chart."""
    d = np.array(b.theta, float)
    for blk, (so, _), v in zip(a.model.blocks, a.model.slices, b.vectors):
        if isinstance(blk.manifold, Sphere) and v @ blk.manifold.v0 <= 0:
            return np.inf
        if blk.manifold.n_params:
            d[so] = blk.manifold.params(v)
    d = d - a.theta
    for blk, (so, _) in zip(a.model.blocks, a.model.slices):
        if isinstance(blk.manifold, Circle):
            d[so] = (d[so] + np.pi) % (2 * np.pi) - np.pi
    return float(np.sqrt(max(d @ a.hessian @ d, 0.0)))


def merge_threshold(ndim, level=OVERLAP_LEVEL):
    """Distance below which two optima are one mode: their ``level`` Laplace
    ellipsoids touch (``2 sqrt(chi2_level(ndim))``)."""
    # chi2.ppf(level, ndim) without importing scipy.stats (about 1 s of start-up)
    return 2.0 * float(np.sqrt(2.0 * gammaincinv(0.5 * ndim, level)))


def group(optima, threshold):
    """Optima merged into modes, most probable first: each optimum joins the
    first more probable mode within ``threshold`` of it, else opens one."""
    modes = []
    for o in sorted(optima, key=lambda o: -o.log_mass):
        if not any(distance(m, o) < threshold for m in modes):
            modes.append(o)
    return modes


def mass_fractions(log_mass):
    """Posterior mass fraction of each mode from its Laplace log mass."""
    lm = np.asarray(log_mass, float)
    w = np.exp(lm - lm.max())
    return w / w.sum()


def starts(model, theta, nominal_vectors=None):
    """(label, axes) of the other least-squares starts (module notes)."""
    vecs = model.unpack(theta)[0][0]
    w = weakest_ground_direction(model)
    free = [k for k, b in enumerate(model.blocks) if b.manifold.n_params]
    out = []

    def moved(v):
        cos = np.clip(np.einsum("kj,kj->k", v, vecs), -1, 1)
        return np.degrees(np.arccos(cos)).max() > SAME_AXIS_DEG

    mirrored = vecs - 2 * np.outer(vecs @ w, w)
    for k in free:
        v = vecs.copy()
        v[k] = mirrored[k]
        if moved(v):
            out.append((f"{model.blocks[k].channel_id}{SINGLE}", v))
    v = vecs.copy()
    v[free] = mirrored[free]
    if len(free) > 1 and moved(v):
        out.append((JOINT, v))
    if nominal_vectors is not None:
        v = vecs.copy()
        v[free] = np.asarray(nominal_vectors, float)[free]
        if moved(v):
            out.append(("nominal axes (metadata)", v))
    return out


def physical(opt):
    """Azimuth, dip (degrees) and gain of each channel at an optimum."""
    az, dip = azimuth_dip(opt.vectors)
    resp = opt.model.response_values(opt.theta[None])
    out = {}
    for k, b in enumerate(opt.model.blocks):
        e = {"azimuth_deg": float(az[k]), "dip_deg": float(dip[k])}
        if b.free != "none":
            vals = resp[b.channel_id][0]
            e["gain"] = float(vals[2])
            if b.free == "all":
                e["period_s"], e["damping"] = float(vals[0]), float(vals[1])
        out[b.channel_id] = e
    return out


def _from_starts(model, theta_ls, nominal_vectors, factors, budget):
    """The optima from the first fit's point and the other starts:
    ``(found, count)``, the distinct optimum of each start (the first fit's
    first) and the count of the starts that came back to it
    (``returned``), those ``budget`` left untried or cut off before their
    polish converged (``skipped``), those the data already rule out
    (``ruled_out``, :func:`_ruled_out`) and those whose polish ran off its
    chart (``off_chart``, :func:`off_chart`)."""
    first = optimum(model, theta_ls, "closed-form start (the first fit)", factors)
    found, count = [first], dict.fromkeys(("returned", "skipped", "ruled_out", "off_chart"), 0)
    singles = {"polished": 0, "distinct": 0}
    todo = starts(model, theta_ls, nominal_vectors)
    n_single = sum(1 for label, _ in todo if label.endswith(SINGLE) and label != JOINT)
    for label, v in todo:
        if budget is not None and budget.spent():
            count["skipped"] += 1
            continue
        if _ruled_out(label, singles, n_single):
            count["ruled_out"] += 1
            continue
        chart = recharted(model, v)
        try:
            o = optimum(chart, theta_for(chart, v, theta_ls), label, factors, first, budget)
        except BudgetSpent:         # cut off mid-polish: not an optimum, not a mode
            count["skipped"] += 1
            continue
        except (np.linalg.LinAlgError, ValueError):
            continue
        if label.endswith(SINGLE) and label != JOINT:
            singles["polished"] += 1
            singles["distinct"] += o is not None      # off its chart: away from the first fit
        if o is None or o is OFF_CHART:
            count["returned" if o is None else "off_chart"] += 1
        else:
            found.append(o)
    return found, count


def _ruled_out(label, singles, n_single):
    """Whether the start ``label`` is one the data already rule out: the
    start with every axis mirrored, once each axis's own mirrored start has
    been polished and at most one of them ended away from the first fit.
    A channel's axis enters only its own rows of the residual, so the
    channels whose mirrors came back are held by the data, and the joint
    start would end where the single starts did."""
    return (label == JOINT and n_single > 0 and singles["polished"] == n_single
            and singles["distinct"] <= 1)


def search(model, theta_ls, nominal_vectors=None, mass=MODE_MASS, budget=None):
    """Least squares from the other starts; returns ``(best, report)``:
    the most probable mode's :class:`Optimum` (its ``label`` says whether it
    is the first fit's) and the ``multimodal`` entry of result.json.

    ``budget`` (a :class:`bayescal.core.budget.Budget`): the search's work;
    once spent, the starts not yet tried are skipped and a start being
    polished is cut off, counted with them (the report's ``not_tried`` and
    ``budget`` say so), never as a mode."""
    factors = model.noise.cholesky()
    with (budget.active() if budget is not None else contextlib.nullcontext()):
        found, count = _from_starts(model, theta_ls, nominal_vectors, factors, budget)
    first = found[0]
    threshold = merge_threshold(model.ndim)
    modes = group(found, threshold)
    if modes[0] is not first and distance(modes[0], first) < threshold:
        modes[0] = first                 # the first fit's mode: keep its point (no restart)
    frac = mass_fractions([m.log_mass for m in modes])
    best = modes[0]
    tried = len(found) + count["returned"] + count["off_chart"]
    report = {
        "detected": bool(len(modes) > 1 and frac[1:].max() >= mass),
        "returned_to_first": count["returned"], "starts": tried + count["skipped"],
        **_counted(count, budget),
        "test": (f"least squares from {tried} starts (closed form, axes mirrored across the "
                 "weakest ground motion, nominal axes); optima within a Mahalanobis distance of "
                 f"{threshold:.2f} (99 % Laplace ellipsoids touching) are one mode; multimodal "
                 f"when a second mode holds at least {mass:g} of the Laplace mass"),
        "mass_threshold": mass,
        "sampled_mode": 0,
        "modes": [{"start": m.label, "mass_fraction": float(f),
                   "log_posterior_difference": m.log_post - best.log_post,
                   "log_mass_difference": m.log_mass - best.log_mass,
                   "distance": distance(best, m) if k else 0.0,
                   "channels": physical(m)} for k, (m, f) in enumerate(zip(modes, frac))],
    }
    return best, report


def _counted(count, budget):
    """The report's entries for the starts not tried, ruled out or run off
    their chart (none when there are none)."""
    out = {}
    if count["skipped"]:
        out.update(not_tried=count["skipped"], budget=budget.note())
    if count["ruled_out"]:
        out.update(ruled_out=count["ruled_out"], ruled_out_why=(
            "the start with every axis mirrored: each axis's own mirrored start was polished "
            "and at most one ended away from the first fit, so the data hold the others"))
    if count["off_chart"]:
        out.update(off_chart=count["off_chart"], off_chart_why=(
            "least squares turned an axis to within a degree of 90 degrees from its start, "
            "where the fit stops changing: no optimum of the posterior"))
    return out
