"""A record's value from its windows' estimates, with a slow wander between them.

Ten-minute windows of one record scatter about the record's value by more
than each window's posterior says, and their errors are correlated over
hours: the relative orientation (or the estimate's bias) wanders. One window
cannot measure that wander; the windows together can. For one scalar
parameter (an azimuth, a gain) with window estimates ``x_i``, their standard
deviations ``s_i`` (each window's posterior) and mid-times ``t_i``, the model is

    x_i = mu + w(t_i) + e_i,    e_i ~ N(0, s_i^2) independent,

``w`` a stationary Ornstein-Uhlenbeck process (Gaussian, mean 0, standard
deviation ``tau``, covariance ``tau^2 exp(-|t - t'| / ell)``), ``mu`` the
record's value. Assumptions: the windows' errors ``e_i`` are Gaussian with
the posterior's sd and independent of one another (consecutive windows share
no data); the wander is stationary over the record, with one time scale;
``mu`` is what a window's estimate averages to over the wander's law.

Computation (:func:`fit_wander`): for each ``(tau, ell)`` of a grid the exact
likelihood in O(n) by a Kalman filter over the (possibly irregular) times,
with ``mu`` integrated analytically under a flat prior (the generalised
least-squares mean and its variance, from the filter's whitened innovations
of ``x`` and of a column of ones). The grid's posterior weights use the prior
:data:`PRIOR`:

* ``tau``: half-Cauchy with scale the windows' median ``s_i`` (``tau = 0``,
  no wander, is on the grid and has the highest prior density; heavy tailed,
  so a wander many times a window's sd is reachable);
* ``ell``: log-uniform from a quarter of the shortest spacing of the windows
  (a wander then acts as extra white scatter) to :data:`ELL_MAX` times the
  record's span. A wander much slower than the record is one offset over
  it, which the windows cannot tell from the record's value: how far
  ``mu``'s interval allows for one is set by this prior, not by the data.
  With no wander (``tau = 0``) the interval of ``mu`` is therefore wider
  than the data alone need (conservative); with a wander slower than
  :data:`ELL_MAX` spans it is too narrow
  (docs/validation/hard_posteriors.md gives the rates).

A common scale (``learn_scale=True``): every window's sd multiplied by one
factor ``lambda`` learned over the record,

    e_i ~ N(0, lambda^2 s_i^2),

for windows fitted with the Gaussian likelihood (``misfit_shape=inf``: each
band's noise scale taken as estimated, no per-band heavy tail), whose sds
carry the misfit's extra variance only as far as the record shows it.
``lambda`` and ``tau`` are told apart by the windows' spread of ``s_i``:
``tau`` dominates the scatter of precise windows, ``lambda`` that of
imprecise ones. Prior: log-uniform on [:data:`SCALE_MIN`, :data:`SCALE_MAX`]
on a grid beside ``tau`` and ``ell``, ``lambda >= 1``: a conservative
choice. A window's sd comes from its own spectra (its noise inflation
floored at the record's, :mod:`bayescal.record.pooling`), and the record
may widen it (noise that is not stationary, a misfit the windows share)
but not narrow it on the strength of the windows' scatter alone; where
``lambda`` truly is 1 the intervals err wide. Whether the intervals reach
the information limit is checked against the per-bin Fisher bound
(docs/validation/hard_posteriors.md).

What it gives: ``mu`` (median and 68/95 % intervals of the mixture over the
grid), ``tau``, ``ell`` and ``lambda`` (median and 95 %), the repeatability ratio
``sqrt(chi2_red)`` of the windows about their inverse-variance weighted
mean without the wander (with
``s_i``) and with it (with ``sqrt(lambda^2 s_i^2 + tau^2)``), and for each
window an interval for the record's value: the window's posterior widened
by the wander, ``N(x_i, lambda^2 s_i^2 + tau^2)`` mixed over the posterior
of ``(lambda, tau)`` (:func:`record_intervals`), or the window's own
samples scaled about their median by ``lambda`` plus draws of
``N(0, tau^2)`` (:func:`widen_samples`).
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

#: The grid's prior, as the docs state it.
PRIOR = {"tau": "half-Cauchy, scale the windows' median sd; grid uniform in tau / (tau + scale)",
         "ell": "log-uniform from a quarter of the shortest window spacing to three times "
                "the record's span",
         "scale": "1 (the windows' sds as given), or learned: log-uniform on [1, 4]"}
#: Grid sizes: tau (0 included), ell.
N_TAU, N_ELL = 64, 32
#: Largest tau on the grid, in units of the prior's scale.
TAU_MAX = 60.0
#: Largest ell on the grid, in units of the record's span.
ELL_MAX = 3.0
#: The learned scale's grid: log-uniform on [SCALE_MIN, SCALE_MAX], N_SCALE points.
SCALE_MIN, SCALE_MAX, N_SCALE = 1.0, 4.0, 29
#: Fewest windows the model is fitted to.
MIN_WINDOWS = 3


@dataclass(frozen=True)
class WanderFit:
    """The wander model fitted to one parameter's windows.

    Attributes
    ----------
    mu, tau, ell, scale : dict
        ``median``, ``ci95`` (and for ``mu``: ``ci68`` and ``sd``, the
        mixture's standard deviation); ``ell`` in the units of ``t``
        (seconds from :mod:`~bayescal.record.values`: ``ell_s`` in
        :meth:`summary`).
    ratio_without, ratio_with : float
        ``sqrt(chi2_red)`` of the window estimates about their
        inverse-variance weighted mean, with sds ``s_i``, and with ``sqrt(lambda^2 s_i^2 + tau^2)``
        (``lambda``, ``tau`` their posterior medians).
    record : (n, 2) array
        Each window's 95 % interval for the record's value
        (:func:`record_intervals`).
    path : (n,) array
        ``mu + E[w(t_i) | x]``: the wander's smoothed path (posterior mean
        over the grid).
    tau_grid, ell_grid, weights : arrays
        The grid and its posterior weights ``(N_TAU, N_ELL)`` (sum 1,
        ``lambda`` summed out).
    scale_grid, scale_tau_weights : arrays
        The grid of ``lambda`` (``[1.0]`` when it is not learned) and the
        posterior of ``(lambda, tau)`` on it and :attr:`tau_grid`
        (``(len(scale_grid), N_TAU)``, sum 1).
    """

    mu: dict
    tau: dict
    ell: dict
    scale: dict
    ratio_without: float
    ratio_with: float
    record: np.ndarray
    path: np.ndarray
    tau_grid: np.ndarray = field(repr=False)
    ell_grid: np.ndarray = field(repr=False)
    weights: np.ndarray = field(repr=False)
    scale_grid: np.ndarray = field(repr=False)
    scale_tau_weights: np.ndarray = field(repr=False)

    @property
    def tau_weights(self):
        """The posterior of ``tau`` on :attr:`tau_grid` (``ell`` summed out)."""
        return self.weights.sum(axis=1)

    def summary(self):
        """The numbers as plain Python (for JSON)."""
        return {"mu": self.mu, "tau": self.tau, "ell_s": self.ell, "scale": self.scale,
                "ratio_without": self.ratio_without, "ratio_with": self.ratio_with,
                "prior": PRIOR}


def kalman_terms(x, s, t, tau, ell, scale=1.0):
    """The whitened sums of the integrated likelihood, for every grid point at once.

    Parameters
    ----------
    x, s, t : (n,) arrays
        Window estimates, their sds and times (sorted by time).
    tau, ell : arrays of one shape ``G``
        The wander's sd and time scale at each grid point.
    scale : float or array of shape ``G``
        The factor on every window's sd (``lambda``).

    Returns
    -------
    dict of arrays of shape ``G``: ``xx``, ``x1``, ``11`` (the quadratic
    forms ``x' K^-1 x``, ``1' K^-1 x``, ``1' K^-1 1`` with ``K`` the
    covariance of ``x`` about ``mu``) and ``logdet`` (``log det K``),
    computed by the Kalman filter of ``w`` (O(n) per grid point).
    """
    tau2 = np.asarray(tau, float) ** 2
    ell = np.asarray(ell, float)
    lam2 = np.asarray(scale, float) ** 2
    zero = np.zeros(np.broadcast(tau2, ell, lam2).shape)
    m_x, m_1, p = zero.copy(), zero.copy(), tau2 + zero       # the stationary start
    out = {"xx": zero.copy(), "x1": zero.copy(), "11": zero.copy(), "logdet": zero.copy()}
    for i in range(len(x)):
        if i:
            phi = np.exp(-(t[i] - t[i - 1]) / ell)
            m_x, m_1 = phi * m_x, phi * m_1
            p = phi ** 2 * p + tau2 * (1 - phi ** 2)
        e2 = lam2 * s[i] ** 2
        f = p + e2
        v_x, v_1 = x[i] - m_x, 1.0 - m_1
        out["xx"] += v_x ** 2 / f
        out["x1"] += v_x * v_1 / f
        out["11"] += v_1 ** 2 / f
        out["logdet"] += np.log(f)
        gain = p / f
        m_x, m_1 = m_x + gain * v_x, m_1 + gain * v_1
        p = p * e2 / f
    return out


def integrated_loglik(terms):
    """Log-likelihood with ``mu`` integrated under a flat prior (up to a
    constant), the GLS mean and its variance, from :func:`kalman_terms`."""
    mean = terms["x1"] / terms["11"]
    quad = terms["xx"] - terms["x1"] ** 2 / terms["11"]
    loglik = -0.5 * (quad + terms["logdet"] + np.log(terms["11"]))
    return loglik, mean, 1.0 / terms["11"]


def grids(s, t):
    """The ``tau`` grid (from 0), its prior weights, and the ``ell`` grid
    (log-uniform, equal prior weights) of :data:`PRIOR`."""
    scale = float(np.median(s))
    q = np.linspace(0.0, TAU_MAX / (1 + TAU_MAX), N_TAU)      # q = tau / (tau + scale)
    tau = scale * q / (1 - q)
    prior_tau = 1.0 / ((1 - q) ** 2 + q ** 2)                  # half-Cauchy times dtau/dq
    prior_tau[[0, -1]] *= 0.5                                   # the trapezoid's ends
    dt = np.diff(t)
    shortest = float(np.min(dt[dt > 0])) if np.any(dt > 0) else 1.0
    span = max(float(t[-1] - t[0]), shortest)
    ell = np.geomspace(shortest / 4, ELL_MAX * span, N_ELL)
    return tau, prior_tau / prior_tau.sum(), ell


def _quantiles(means, sds, weights, probs, iterations=60):
    """Quantiles of normal mixtures ``sum_k weights_k N(means_k, sds_k^2)``,
    one mixture per row of ``means`` and ``sds`` ``(B, K)`` (weights ``(K,)``
    shared), by bisection; returns ``(B, len(probs))``."""
    from scipy.special import ndtr
    means, sds = np.atleast_2d(means), np.atleast_2d(sds)
    w = np.asarray(weights, float) / np.sum(weights)
    probs = np.asarray(probs, float)[None, :]
    lo = np.min(means - 9 * sds, axis=1)[:, None] + 0 * probs
    hi = np.max(means + 9 * sds, axis=1)[:, None] + 0 * probs
    for _ in range(iterations):
        mid = 0.5 * (lo + hi)
        cdf = np.sum(w[None, None, :] * ndtr((mid[..., None] - means[:, None, :])
                                              / sds[:, None, :]), axis=-1)
        below = cdf < probs
        lo, hi = np.where(below, mid, lo), np.where(below, hi, mid)
    return 0.5 * (lo + hi)


def _grid_quantiles(values, weights, probs):
    """Quantiles of a discrete distribution on sorted ``values``
    (linear between the grid points)."""
    cdf = np.cumsum(weights)
    mid = cdf - 0.5 * weights
    return np.interp(probs, mid, values)


def _scale_tau(tau_grid, weights, scale_grid):
    """``(lambda, tau, weight)`` of each grid point, flattened: ``weights``
    on ``tau_grid`` ``(N,)`` or on ``scale_grid`` x ``tau_grid`` ``(L, N)``."""
    w = np.atleast_2d(np.asarray(weights, float))
    lam = np.asarray(scale_grid, float).reshape(-1, 1) + 0 * w
    tau = np.asarray(tau_grid, float)[None, :] + 0 * w
    return lam.ravel(), tau.ravel(), w.ravel() / w.sum()


def record_intervals(x, s, tau_grid, tau_weights, level=0.95, scale_grid=(1.0,)):
    """Each window's interval for the record's value:
    ``N(x_i, lambda^2 s_i^2 + tau^2)`` mixed over the posterior of ``tau``
    (``tau_weights`` on ``tau_grid``) or of ``(lambda, tau)``
    (``tau_weights`` of shape ``(len(scale_grid), len(tau_grid))``).

    Returns
    -------
    (n, 2) array of the ``level`` central intervals.
    """
    x, s = np.asarray(x, float), np.asarray(s, float)
    lam, tau, w = _scale_tau(tau_grid, tau_weights, scale_grid)
    keep = w > 1e-12 * np.max(w)
    sd = np.sqrt((lam[keep][None, :] * s[:, None]) ** 2 + tau[keep][None, :] ** 2)
    return _quantiles(x[:, None] + 0 * sd, sd, w[keep], [(1 - level) / 2, (1 + level) / 2])


def widen_samples(samples, tau_grid, tau_weights, rng, scale_grid=(1.0,)):
    """A window's posterior samples widened by the wander: each sample's
    distance from the samples' median multiplied by ``lambda``, plus a draw
    of ``N(0, tau^2)``, ``(lambda, tau)`` drawn from their posterior
    (``tau_weights`` as :func:`record_intervals` takes them); their
    quantiles are the window's interval for the record's value."""
    samples = np.asarray(samples, float)
    lam, tau, w = _scale_tau(tau_grid, tau_weights, scale_grid)
    k = rng.choice(w.size, size=samples.shape, p=w)
    centre = np.median(samples)
    return (centre + lam[k] * (samples - centre)
            + tau[k] * rng.standard_normal(samples.shape))


def smoothed_path(x, s, t, tau, ell, mean, scale=1.0):
    """``E[w(t_i) | x, mu = mean]`` at each grid point (the Rauch-Tung-Striebel
    smoother of the OU wander); arrays ``tau``, ``ell``, ``mean`` (and
    ``scale``, the factor on the sds) of one shape ``G``. Returns ``(n, G)``."""
    n = len(x)
    tau2 = tau ** 2
    lam2 = np.asarray(scale, float) ** 2
    m_f, p_f = np.empty((n,) + tau.shape), np.empty((n,) + tau.shape)
    m_p, p_p = np.zeros_like(m_f), np.empty_like(p_f)
    phis = np.exp(-np.diff(t)[:, None] / ell[None, :]) if n > 1 else np.empty((0,) + tau.shape)
    p_p[0] = tau2
    for i in range(n):
        if i:
            m_p[i] = phis[i - 1] * m_f[i - 1]
            p_p[i] = phis[i - 1] ** 2 * p_f[i - 1] + tau2 * (1 - phis[i - 1] ** 2)
        e2 = lam2 * s[i] ** 2
        f = p_p[i] + e2
        m_f[i] = m_p[i] + p_p[i] / f * (x[i] - mean - m_p[i])
        p_f[i] = p_p[i] * e2 / f
    m_s = m_f.copy()
    for i in range(n - 2, -1, -1):
        c = np.divide(p_f[i] * phis[i], p_p[i + 1], out=np.zeros_like(tau),
                      where=p_p[i + 1] > 0)
        m_s[i] = m_f[i] + c * (m_s[i + 1] - m_p[i + 1])
    return m_s


def grid_posterior(x, s, t, learn_scale=False):
    """The posterior on the grid ``(lambda, tau, ell)`` of :data:`PRIOR`
    for window estimates sorted by time.

    Returns
    -------
    dict: ``scale``, ``tau``, ``ell`` (the grids, ``scale`` ``[1.0]`` when
    not learned), ``lam3``, ``tau3``, ``ell3`` (each point's values),
    ``weights`` (sum 1), ``mean`` and ``var`` (``mu``'s conditional
    Gaussian at each point), all of shape ``(L, N_TAU, N_ELL)``.
    """
    tau_g, prior_tau, ell_g = grids(s, t)
    lam_g = np.geomspace(SCALE_MIN, SCALE_MAX, N_SCALE) if learn_scale else np.ones(1)
    lam3, tau3, ell3 = np.meshgrid(lam_g, tau_g, ell_g, indexing="ij")
    loglik, mean, var = integrated_loglik(kalman_terms(x, s, t, tau3, ell3, lam3))
    logw = loglik + np.log(prior_tau)[None, :, None]          # lambda: equal weights on its log grid
    weights = np.exp(logw - logw.max())
    return {"scale": lam_g, "tau": tau_g, "ell": ell_g, "lam3": lam3, "tau3": tau3, "ell3": ell3,
            "weights": weights / weights.sum(), "mean": mean, "var": var}


def _summary(values, weights, log=False):
    """Median and 95 % interval of a grid's marginal posterior."""
    v = np.log(values) if log else values
    q = _grid_quantiles(v, weights, [0.5, 0.025, 0.975])
    q = np.exp(q) if log else q
    return {"median": float(q[0]), "ci95": [float(q[1]), float(q[2])]}


def fit_wander(x, s, t, level=0.95, learn_scale=False):
    """Fit the wander model to one parameter's window estimates.

    Parameters
    ----------
    x, s : (n,) array_like
        Window estimates (posterior medians) and standard deviations (half
        the 68 % width of each window's posterior), n >= :data:`MIN_WINDOWS`.
    t : (n,) array_like
        The windows' times (e.g. seconds of their mid-points), any spacing.
    level : float
        The level of each window's interval for the record's value.
    learn_scale : bool
        Learn a common factor ``lambda`` on the sds (module docstring);
        otherwise ``lambda = 1``.

    Returns
    -------
    WanderFit

    Raises
    ------
    InputError
        Fewer than :data:`MIN_WINDOWS` windows, or an sd not positive.
    """
    from ..core.checks import reduced_chi_square
    from ..errors import InputError
    x, s, t = (np.asarray(a, float) for a in (x, s, t))
    if x.size < MIN_WINDOWS or not np.all(s > 0) or not (x.shape == s.shape == t.shape):
        raise InputError(f"the wander model needs at least {MIN_WINDOWS} windows, each with "
                         f"a positive sd (given {x.size})")
    order = np.argsort(t, kind="stable")
    xs, ss, ts = x[order], s[order], t[order]
    g = grid_posterior(xs, ss, ts, learn_scale)
    weights, mean, var = g["weights"], g["mean"], g["var"]
    keep = weights > 1e-12 * weights.max()
    lo95, lo68, med, hi68, hi95 = _quantiles(mean[keep], np.sqrt(var[keep]), weights[keep],
                                             [0.025, 0.16, 0.5, 0.84, 0.975])[0]
    sd = float(np.sqrt(np.sum(weights * (var + mean ** 2)) - np.sum(weights * mean) ** 2))
    tau_ell, scale_tau = weights.sum(axis=0), weights.sum(axis=2)
    tau_q = _summary(g["tau"], tau_ell.sum(axis=1))
    lam_q = _summary(g["scale"], scale_tau.sum(axis=1), log=True) if learn_scale else {
        "median": 1.0, "ci95": [1.0, 1.0]}
    keep = weights > 1e-6 * weights.max()
    paths = smoothed_path(xs, ss, ts, g["tau3"][keep], g["ell3"][keep], mean[keep],
                          g["lam3"][keep]) + mean[keep]
    path = np.empty_like(xs)
    path[order] = (paths * weights[keep]).sum(axis=1) / weights[keep].sum()
    return WanderFit(
        mu={"median": float(med), "ci68": [float(lo68), float(hi68)],
            "ci95": [float(lo95), float(hi95)], "sd": sd},
        tau=tau_q, ell=_summary(g["ell"], tau_ell.sum(axis=0), log=True), scale=lam_q,
        ratio_without=reduced_chi_square(x, s)[1],
        ratio_with=reduced_chi_square(x, np.sqrt((lam_q["median"] * s) ** 2
                                                 + tau_q["median"] ** 2))[1],
        record=record_intervals(x, s, g["tau"], scale_tau, level, g["scale"]),
        path=path, tau_grid=g["tau"], ell_grid=g["ell"], weights=tau_ell,
        scale_grid=g["scale"], scale_tau_weights=scale_tau)


def draw_wander(t, tau, ell, rng):
    """An exact draw of the stationary wander (sd ``tau``, time scale
    ``ell``) at the sorted times ``t``: what the model assumes, for
    simulations with a known wander."""
    t = np.asarray(t, float)
    w = np.empty(t.size)
    w[0] = tau * rng.standard_normal()
    for i in range(1, t.size):
        phi = np.exp(-(t[i] - t[i - 1]) / ell)
        w[i] = phi * w[i - 1] + tau * np.sqrt(1 - phi ** 2) * rng.standard_normal()
    return w
