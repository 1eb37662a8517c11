"""Noise scales marginalised: intervals that widen where the residual is
larger than the noise model allows. By default a scale per band; on request
(:data:`OWN_SCALE_PROB` below 1, :data:`SCALE_FLOOR` on) one scale pooled
across bands with each band allowed its own where it alone misses.

The Gaussian likelihood of band b is ``-q_b`` with ``q_b`` the whitened
residual energy (complex form: ``q_b = tr(A_b R_b B_b R_b^H)``; real form:
``chi2_b / 2``), which is Gamma(k_b, 1) where the model fits, ``k_b`` the
band's complex degrees of freedom (half its real ones). A band whose plug-in
noise model carries sampling error enters with weight ``w_b``
(:mod:`bayescal.core.model.plugin`).

**Per band (the default).** Band b's noise covariance times a scale
``s_b ~ InverseGamma(a, a)``, integrated out:
``int s^-k exp(-q / s) IG(s; a, a) ds ∝ (1 + q / a)^-(a + k)``, so each band
contributes ``-w_b (a + k_b) log(1 + q_b / a)`` and its variance is scaled
by about ``(a + q_b) / (a + k_b)``, below 1 where ``q_b < k_b``.

**Per band, its factor floored** (on request, :data:`FACTOR_FLOOR` ``f0 >
0``). The term's slope in ``q_b`` is ``min(1 / f0, (a + k_b) / (a + q_b))``:
the Gaussian of variance ``f0`` times the noise model's up to ``q* = f0 (a +
k_b) - a``, the marginal's above, joined in value and slope, so that a band
whose residual is small by chance does not narrow the intervals below
``f0`` times the noise model's while a band that misses keeps the
marginal's widening. A floor on the variance factor, not on the prior of
``s_b`` (which widens every band that fits, ``SCALE_FLOOR``).

**Pooled.** With ``Q_b = w_b q_b`` and ``K_b = w_b k_b``, band b's noise
covariance is multiplied by a scale ``s_b``. With probability
``1 - pi`` the band shares the pooled scale ``s0`` (``s_b = s0``); with
probability ``pi`` (:data:`OWN_SCALE_PROB`, independently per band) it has
its own. Both scales have an inverse-gamma prior of shape and scale ``a``
restricted to ``s >= 1``. In ``u = 1 / s0`` (Gamma(a, a) restricted to
``u <= 1``) the band's term given ``u`` is

    g_b(u) = (1 - pi) u^K_b exp(-Q_b u) + pi C_b,
    C_b = a^a / (Gamma(a) P(a, a)) Gamma(a + K_b) (a + Q_b)^-(a + K_b) P(a + K_b, a + Q_b),

``C_b`` the band's own scale integrated out (``P`` the regularised lower
incomplete gamma function), and the likelihood is
``log int_0^1 Gamma(u; a, a) prod_b g_b(u) du / P(a, a)``. Expanding the
product gives a sum over which bands keep the pooled scale, each term closed
form: with ``S`` the pooled bands, ``Q_S``, ``K_S`` their sums,

    int_0^1 Gamma(u; a, a) u^K_S exp(-Q_S u) du
        = a^a / Gamma(a) Gamma(a + K_S) (a + Q_S)^-(a + K_S) P(a + K_S, a + Q_S).

Up to 8 bands every configuration is summed (256 at most); with more bands
only those with the fewest own scales (:func:`max_own`), so that the cost
stays at most :data:`MAX_CONFIGS` terms a walker.

**Per SUT channel** (on request, :data:`PER_CHANNEL`): any form above
applied to each SUT channel's share of the bands' energies instead of the
band's whole (:mod:`bayescal.core.model.channel_scale`), so that the
channels widen apart.

In the pooled form, where the model fits, the bands pool their residual
into one scale learned from all ``K = sum K_b`` degrees of freedom (light tails: about
``2 (a + K)`` degrees of freedom) and every band's variance is scaled by
about 1; a uniformly larger residual widens every band by the pooled ratio
``(a + Q) / (a + K)``; a band whose residual alone is too large takes its
own scale, ``(a + Q_b) / (a + K_b)``, and leaves the others pooled. The
restriction ``s >= 1`` is there because the noise model is measured on the
same residual, so that ``Q`` reads a little below ``K`` where the model
fits; a free scale would undo the segment-scatter inflation and narrow
intervals below what the data hold. ``a = inf`` is the Gaussian. Derivation,
the choice of ``a`` and ``pi``, and measurements: docs/validation/misfit_scale.md.
"""
from __future__ import annotations

from functools import lru_cache
from itertools import combinations
from math import comb

import numpy as np
from scipy.special import gammainc, gammaln, logsumexp

#: Shape (and scale) of the inverse-gamma priors of the pooled and the own
#: noise scales used by a fit (docs/validation/misfit_scale.md says why).
MISFIT_SHAPE = 2.0
#: Prior probability that a band has its own noise scale instead of the
#: pooled one; 1 (the default): a scale per band
#: (docs/validation/misfit_scale.md says why).
OWN_SCALE_PROB = 1.0

#: Whether every scale is restricted to ``s >= 1`` (the noise model a
#: floor: never narrower than it). False: the inverse-gamma priors over all
#: ``s > 0``; with ``OWN_SCALE_PROB = 1`` that is a scale per band,
#: ``-(a + k_b) log(1 + q_b / a)`` each.
SCALE_FLOOR = False
#: The least variance factor of the scale per band, on request: where a
#: band's residual energy is below ``FACTOR_FLOOR (a + k_b) - a`` its term is
#: Gaussian with the noise model's variance times this factor, above it the
#: marginal's, joined in value and slope (module notes). 0 (the default):
#: the marginal ``-(a + k_b) log(1 + q_b / a)`` over every ``q_b``.
FACTOR_FLOOR = 0.0
#: Whether each SUT channel has its own noise scales, the form above applied
#: to the channel's share of each band's whitened residual energy
#: (:mod:`bayescal.core.model.channel_scale`), instead of the band's scales
#: shared by its channels. False (the default): shared.
PER_CHANNEL = False
#: At most this many configurations of pooled and own bands are summed:
#: every one for up to 8 bands, else those with the fewest own scales.
MAX_CONFIGS = 256


def log_lower_gamma(s, x):
    """``log P(s, x)``, the regularised lower incomplete gamma function, also
    where ``P`` underflows (``x`` far below ``s``: its power series)."""
    s, x = np.broadcast_arrays(np.asarray(s, float), np.asarray(x, float))
    shape = x.shape
    s, x = s.ravel(), x.ravel()
    p = gammainc(s, x)
    out = np.log(np.where(p > 1e-300, p, 1.0))
    small = p <= 1e-300
    if np.any(small):
        xs, ss = x[small], s[small]
        # P(s, x) = x^s e^-x / Gamma(s + 1) sum_n x^n / ((s + 1) ... (s + n))
        n = np.arange(1, 400)
        terms = np.cumsum(np.log(xs)[:, None] - np.log(ss[:, None] + n[None, :]), axis=1)
        series = logsumexp(np.concatenate([np.zeros((xs.size, 1)), terms], axis=1), axis=1)
        out[small] = ss * np.log(xs) - xs - gammaln(ss + 1) + series
    return out.reshape(shape)


def _weighted(q, k, weight):
    """``(Q, K)``: ``q`` (W, B) and ``k`` (B,) times each band's weight."""
    q = np.atleast_2d(np.asarray(q, float))
    w = np.ones(q.shape[-1]) if weight is None else np.asarray(weight, float)
    return q * w, np.asarray(k, float) * w


def _log_prior_mass(a):
    """``log P(a, a)``: the mass of Gamma(a, a) on ``u <= 1`` (0 without
    the floor, :data:`SCALE_FLOOR`)."""
    return float(log_lower_gamma(a, a)) if SCALE_FLOOR else 0.0


def own_scale_loglik(big_q, big_k, a):
    """``log C_b``: a band's term with its own scale integrated out over the
    inverse-gamma(a, a) prior restricted to ``s >= 1`` (module notes), for
    weighted energies ``big_q`` (..., B) and degrees of freedom ``big_k`` (B,)."""
    return _pooled_loglik(np.asarray(big_q, float), big_k, a) - _log_prior_mass(a)


def max_own(n_bands):
    """The largest number of bands allowed their own scale at once: all of
    them for ``n_bands <= 8``, else the most whose configurations number at
    most :data:`MAX_CONFIGS` (4 for 9 bands, 3 for 10-11, 2 for 12-22)."""
    count, m = 0, 0
    for j in range(n_bands + 1):
        count += comb(n_bands, j)
        if count > MAX_CONFIGS:
            break
        m = j
    return m


@lru_cache(maxsize=64)
def configurations(n_bands, pi):
    """``(pooled, log_prior)``: (C, B) 0/1, 1 where band b shares the pooled
    scale, for every configuration with at most :func:`max_own` own bands,
    and each one's log prior probability ``j log pi + (B - j) log(1 - pi)``
    (``j`` own bands) renormalised over them (``pi = 0``: the pooled one
    alone; ``pi = 1``: every band its own)."""
    if pi >= 1:                                   # every band its own scale
        return np.zeros((1, n_bands)), np.zeros(1)
    rows = [np.ones(n_bands)]
    for j in range(1, (max_own(n_bands) if pi > 0 else 0) + 1):
        for own in combinations(range(n_bands), j):
            row = np.ones(n_bands)
            row[list(own)] = 0.0
            rows.append(row)
    pooled = np.array(rows)
    n_own = n_bands - pooled.sum(axis=1)
    log_prior = n_own * np.log(pi, where=n_own > 0, out=np.zeros_like(n_own)) \
        + (n_bands - n_own) * np.log1p(-pi)
    return pooled, log_prior - logsumexp(log_prior)


def _pooled_loglik(big_q, big_k, a, moment=0):
    """``log int_0^1 u^moment Gamma(u; a, a) u^K exp(-Q u) du`` for pooled
    energies ``big_q`` and degrees of freedom ``big_k`` (broadcast)."""
    s, x = a + big_k + moment, a + big_q
    out = a * np.log(a) - gammaln(a) + gammaln(s) - s * np.log(x)
    return out + log_lower_gamma(s, x) if SCALE_FLOOR else out


def _config_terms(q, k, a, weight, pi):
    """Each configuration's log term (W, C) (its prior, the pooled bands'
    integral, the own bands' ``log C_b``) and what the variance factors
    need: the pooled indicator, ``(Q, K)`` and the pooled sums."""
    big_q, big_k = _weighted(q, k, weight)
    pooled, log_prior = configurations(big_q.shape[1],
                                       float(OWN_SCALE_PROB if pi is None else pi))
    q_s, k_s = big_q @ pooled.T, pooled @ big_k                      # (W, C), (C,)
    log_own = own_scale_loglik(big_q, big_k, a)                      # (W, B)
    terms = log_prior + _pooled_loglik(q_s, k_s, a) + log_own @ (1.0 - pooled).T
    return terms, pooled, big_q, big_k, q_s, k_s


def _per_band(pi):
    """Whether the default scale per band applies: every band its own scale,
    free below 1 (its weight multiplying the band's whole term)."""
    return (OWN_SCALE_PROB if pi is None else pi) >= 1 and not SCALE_FLOOR


def floored_band_terms(q, k, a, floor):
    """(W, B) each band's term of the scale per band with its variance factor
    at least ``floor`` (:data:`FACTOR_FLOOR`; module notes), unweighted:
    ``-q / floor`` for ``q <= q*``, ``q* = floor (a + k) - a``, else
    ``-q* / floor - (a + k) log((a + q) / (a + q*))`` (``floor = 0``: the
    marginal, ``-(a + k) log(1 + q / a)``)."""
    q, k = np.asarray(q, float), np.asarray(k, float)
    if floor <= 0:
        return -(a + k) * np.log1p(q / a)
    q_star = floor * (a + k) - a
    with np.errstate(divide="ignore", invalid="ignore"):
        tail = q_star / floor + (a + k) * np.log((a + q) / (a + q_star))
    return -np.where(q <= q_star, q / floor, tail)


def band_loglik(q, k, a, weight=None, pi=None, floor=None):
    """Log likelihood over the bands with the noise scales marginalised.

    Parameters
    ----------
    q : (W, B) whitened residual energy per band (the Gaussian term is ``-q``).
    k : (B,) complex degrees of freedom of each band's residual.
    a : prior shape; ``inf`` (or None) gives the Gaussian ``-sum w q``.
    weight : (B,) or None, each band's term multiplied by it (the plug-in
        noise model's sampling error, :mod:`bayescal.core.model.plugin`).
    pi : each band's prior probability of its own scale (0: one pooled
        scale; None: :data:`OWN_SCALE_PROB`).
    floor : the scale per band's least variance factor (None:
        :data:`FACTOR_FLOOR`; 0: the plain marginal).

    Returns
    -------
    (W,) the log of the sum over configurations (:func:`configurations`)
    of each one's prior times its closed-form marginal (module notes); 0 at
    ``q = 0`` in the Gaussian limit.
    """
    if a is None or not np.isfinite(a):
        return -np.sum(_weighted(q, k, weight)[0], axis=1)
    if _per_band(pi):
        w = 1.0 if weight is None else np.asarray(weight, float)
        terms = floored_band_terms(q, k, a, FACTOR_FLOOR if floor is None else floor)
        return np.sum(w * terms, axis=1)
    return logsumexp(_config_terms(q, k, a, weight, pi)[0], axis=1) - _log_prior_mass(a)


def band_scale(q, k, a, weight=None, pi=None, floor=None):
    """(B,) the factor ``1 / E[1 / s_b | q]`` by which each band's noise
    variance is effectively scaled at residual energies ``q`` (B,): the
    inverse of the likelihood's slope in ``Q_b``; for the scale per band at
    least ``floor`` (None: :data:`FACTOR_FLOOR`), for the pooled one with
    :data:`SCALE_FLOOR` at least 1; 1 for ``a = inf``."""
    q = np.asarray(q, float)
    if a is None or not np.isfinite(a):
        return np.ones(q.shape[-1])
    if _per_band(pi):
        return np.maximum((a + q) / (a + np.asarray(k, float)),
                          FACTOR_FLOOR if floor is None else floor)
    terms, pooled, big_q, big_k, q_s, k_s = _config_terms(q[None], k, a, weight, pi)
    post = np.exp(terms[0] - logsumexp(terms[0]))                              # (C,)
    # E[u | configuration] for the pooled scale, E[u_b] for a band's own
    e_pooled = np.exp(_pooled_loglik(q_s[0], k_s, a, 1) - _pooled_loglik(q_s[0], k_s, a))
    e_own = np.exp(_pooled_loglik(big_q[0], big_k, a, 1) - _pooled_loglik(big_q[0], big_k, a))
    e_inv = (post * e_pooled) @ pooled + post @ (1.0 - pooled) * e_own
    return 1.0 / e_inv


def describe(a, q=None, k=None, weight=None):
    """The ``result.json`` entry ``meta.misfit_scale``."""
    gaussian = a is None or not np.isfinite(a)
    if gaussian:
        model = "Gaussian noise model (no misfit scale)"
    elif _per_band(None):
        model = (f"per-band noise scale s_b ~ InverseGamma({a:g}, {a:g}), marginalised: each "
                 "band's term is -(a + k_b) log(1 + q_b / a); bands whose residual exceeds "
                 "the noise model are down-weighted and intervals widen"
                 + (f"; each band's variance factor at least {FACTOR_FLOOR:g} (below "
                    f"q_b = {FACTOR_FLOOR:g} (a + k_b) - a its term is Gaussian)" if FACTOR_FLOOR > 0 else "")
                 + " (docs/validation/misfit_scale.md)")
    else:
        model = (f"one noise scale pooled across bands, each band with probability "
                 f"{OWN_SCALE_PROB:g} its own; every scale s ~ InverseGamma({a:g}, {a:g})"
                 + (" restricted to s >= 1" if SCALE_FLOOR else "") + ", marginalised: a "
                 "residual beyond the noise model widens all bands by the pooled ratio, or one "
                 "band alone where only it misses (docs/validation/misfit_scale.md)")
    per_channel = PER_CHANNEL and not gaussian
    if per_channel:
        model = ("a noise scale per SUT channel, its share of each band's whitened residual "
                 "energy, each channel's scales: " + model)
    out = {"shape_a": None if gaussian else float(a), "model": model}
    if per_channel:
        out["per_channel"] = True
    if not gaussian and not _per_band(None):
        out.update(own_scale_prob=OWN_SCALE_PROB, scale_floor=SCALE_FLOOR)
    elif not gaussian and FACTOR_FLOOR > 0:
        out["factor_floor"] = FACTOR_FLOOR
    if q is not None and not per_channel:
        out["band_variance_factor"] = [round(float(v), 4) for v in band_scale(q, k, a, weight)]
    return out
