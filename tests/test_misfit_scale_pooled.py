"""The pooled noise scale (bayescal.core.model.misfit_scale with
``SCALE_FLOOR`` on and ``OWN_SCALE_PROB`` below 1): one scale pooled across
bands, each band with prior probability pi its own, both inverse-gamma(a, a)
restricted to s >= 1. The closed form against numerical
integration over the scales; the variance factors against the likelihood's
slope; pooling where the model holds and one band alone widening where only
it misses (q_b drawn from its closed-form distribution Gamma(k_b, 1)); and on
simulated pairs: intervals widen where the model misses (a timing offset the
model leaves out) and stay as they were where it fits."""
import itertools

import numpy as np
import pytest
from scipy.integrate import simpson
from scipy.special import gammaln
from scipy.stats import gamma

from bayescal.core.model import misfit_scale
from bayescal.core.model.misfit_scale import band_loglik, band_scale, max_own
from bayescal.pair.workflow import calibrate
from bayescal.simulate.pair import simulate_pair
from tests.tolerance import Z_001

A, PI = 2.0, 0.25


@pytest.fixture(autouse=True)
def pooled_scale(monkeypatch):
    """The pooled model (floor on, own scales at probability PI) for every
    test here, the fits' included."""
    monkeypatch.setattr(misfit_scale, "SCALE_FLOOR", True)
    monkeypatch.setattr(misfit_scale, "OWN_SCALE_PROB", PI)


def _log_integral(f):
    """log int_0^1 f(u) du for a positive integrand given as its log
    (vectorised), by Simpson's rule in v = log u on 100001 points of
    [-20, 0] (spacing 2e-4: the sharpest integrand here is 0.05 wide)."""
    v = np.linspace(-20.0, 0.0, 100001)
    logs = f(np.exp(v)) + v
    top = logs.max()
    return np.log(simpson(np.exp(logs - top), x=v)) + top


def _own(qb, kb, a):
    """log of a band's term with its own scale: int_1^inf s^-k exp(-q/s) IG(s; a, a) ds
    over the prior restricted to s >= 1 (numerically, in u = 1/s)."""
    log_prior_mass = _log_integral(lambda u: gamma.logpdf(u, a, scale=1 / a))
    return _log_integral(lambda u: gamma.logpdf(u, a, scale=1 / a) + kb * np.log(u) - qb * u) \
        - log_prior_mass


def _numeric(q, k, a, w, pi, configs=None):
    """The likelihood as int Gamma(u; a, a) prod_b [(1 - pi) u^K_b e^(-Q_b u) + pi C_b] du
    over u <= 1 (over the prior's mass there); with ``configs`` (pooled
    indicators) the sum over those configurations of their integrals, each
    with its renormalised prior."""
    big_q, big_k = np.asarray(q) * w, np.asarray(k) * w
    own = np.array([_own(qb, kb, a) for qb, kb in zip(big_q, big_k)])
    mass = _log_integral(lambda u: gamma.logpdf(u, a, scale=1 / a))
    if configs is None:
        return _log_integral(lambda u: gamma.logpdf(u, a, scale=1 / a) + np.sum(np.logaddexp(
            np.log1p(-pi) + big_k * np.log(u)[:, None] - big_q * u[:, None], np.log(pi) + own),
            axis=1)) - mass
    terms, priors = [], []
    for s in configs:
        s = np.asarray(s, bool)
        prior = (~s).sum() * np.log(pi) + s.sum() * np.log1p(-pi)
        priors.append(prior)
        terms.append(prior + own[~s].sum() + _log_integral(
            lambda u: gamma.logpdf(u, a, scale=1 / a) + big_k[s].sum() * np.log(u)
            - big_q[s].sum() * u))
    return np.logaddexp.reduce(terms) - np.logaddexp.reduce(priors) - mass


@pytest.mark.parametrize("k,w", [([4.0, 4.0, 4.0], [1.0, 1.0, 1.0]),
                                 ([4.0, 4.0, 6.0], [0.6, 0.7, 0.8]),
                                 ([300.0, 300.0, 300.0], [1.0, 1.0, 1.0])])
def test_closed_form_is_the_integral_over_the_scales(k, w):
    rng = np.random.default_rng(1)
    k, w = np.array(k), np.array(w)
    for m in (0.3, 1.3, 30.0):
        q = rng.uniform(0.5, 1.5, k.size) * k * m
        for qq in (q, q * np.array([20.0] + [1.0] * (k.size - 1))):
            assert band_loglik(qq[None], k, A, w, PI)[0] == pytest.approx(
                _numeric(qq, k, A, w, PI), abs=1e-6 * max(1.0, abs(qq.sum())))


def test_many_bands_sum_the_configurations_with_fewest_own_scales():
    """Ten bands: at most three own scales at once (176 configurations),
    each configuration integrated numerically."""
    b = 10
    assert [max_own(n) for n in (8, 9, 10, 11, 12, 18, 22, 23)] == [8, 4, 3, 3, 2, 2, 2, 1]
    configs = [c for c in itertools.product([1, 0], repeat=b) if b - sum(c) <= 3]
    k, w = np.full(b, 4.0), np.linspace(0.6, 1.0, b)
    q = np.random.default_rng(2).gamma(k) * np.array([1.0] * 8 + [8.0, 30.0])
    assert band_loglik(q[None], k, A, w, PI)[0] == pytest.approx(
        _numeric(q, k, A, w, PI, configs), abs=1e-6)


@pytest.mark.parametrize("q_over_k", [0.5, 1.0, 2.0, 10.0])
def test_variance_factor_is_the_slope_and_at_least_one(q_over_k):
    """Each band's factor is 1 / E[1/s_b | q], the inverse of the
    likelihood's slope in Q_b = w_b q_b (finite difference)."""
    k, w = np.array([4.0, 4.0, 6.0]), np.array([0.6, 0.7, 0.8])
    q = q_over_k * k * np.array([1.0, 1.3, 6.0])
    f = band_scale(q, k, A, w, PI)
    for b in range(3):
        h = 1e-5 * q[b]
        up, down = q.copy(), q.copy()
        up[b] += h
        down[b] -= h
        slope = (band_loglik(up[None], k, A, w, PI) - band_loglik(down[None], k, A, w, PI))[0]
        assert -slope / (2 * h * w[b]) == pytest.approx(1 / f[b], rel=1e-5)
    assert np.all(f >= 1.0)


def test_gaussian_and_pooled_limits():
    q = np.array([[3.0, 40.0]])
    assert band_loglik(q, [3.0, 3.0], np.inf, [1.0, 0.5])[0] == -23.0
    assert band_scale(q[0], [3.0, 3.0], np.inf).tolist() == [1.0, 1.0]
    # pi = 0: one pooled scale, -(a + K) log(a + Q) + log P(a + K, a + Q) + const
    from scipy.special import gammainc
    k = np.array([4.0, 4.0, 4.0])
    qs = np.array([[2.0, 3.0, 5.0], [10.0, 30.0, 1.0], [40.0, 40.0, 40.0]])
    got = band_loglik(qs, k, A, None, 0.0)
    big_q, big_k = qs.sum(axis=1), k.sum()
    closed = (gammaln(A + big_k) - (A + big_k) * np.log(A + big_q)
              + np.log(gammainc(A + big_k, A + big_q)))
    assert np.allclose(got - got[0], closed - closed[0], rtol=0, atol=1e-10)


def _pooling_draws(k, n, rng):
    """Over ``n`` draws of q_b ~ Gamma(k, 1) in 5 bands: each draw's largest
    relative deviation of a band's factor from the one pooled scale's
    (pi = 0); then, band 0's residual made ten times larger, band 0's factor
    over its own ratio (a + Q_0) / (a + K_0) and the other bands' largest
    deviation from the pooled scale of those four alone."""
    kk = np.full(5, k)
    dev, alone, others = [], [], []
    for _ in range(n):
        q = rng.gamma(kk)
        dev.append(np.max(np.abs(band_scale(q, kk, A, None, PI)
                                 / band_scale(q, kk, A, None, 0.0) - 1)))
        q[0] *= 10
        f = band_scale(q, kk, A, None, PI)
        alone.append(f[0] * (A + k) / (A + q[0]))
        others.append(np.max(np.abs(f[1:] / band_scale(q[1:], kk[1:], A, None, 0.0) - 1)))
    return np.array(dev), np.array(alone), np.array(others)


def test_bands_pool_where_the_model_holds_and_one_band_widens_alone():
    """q_b ~ Gamma(k_b, 1), the model holding (5 bands, 200 seeded draws for
    each k of 9, 36 and 144 degrees of freedom a band). Every band's factor
    tends to the one pooled scale's: the median deviation falls as k grows
    and is under 1 % at k = 144. With band 0's
    residual ten times larger, band 0 alone takes its own ratio
    (a + Q_0) / (a + K_0) (within 1 % in 98 % of draws) and the other four
    keep their own pooled scale as closely as bands do where nothing misses
    (median and 98 % point of the deviation within 0.01 and 0.02 of those)."""
    rng = np.random.default_rng(5)
    medians = []
    for k in (9.0, 36.0, 144.0):
        dev, alone, others = _pooling_draws(k, 200, rng)
        medians.append(np.median(dev))
        assert np.mean(np.abs(alone - 1) < 0.01) >= 0.98, (k, np.quantile(alone, [0.02, 0.5]))
        assert np.median(others) <= np.median(dev) + 0.01, (k, np.median(others), medians)
        assert np.quantile(others, 0.98) <= np.quantile(dev, 0.98) + 0.02, k
    assert medians[0] > medians[1] > medians[2] and medians[2] < 0.01, medians


def _gain_sds(sim, shapes):
    out = []
    for a in shapes:
        post = calibrate(sut=sim.sut, sut_xml=sim.sut_inventory, ref=sim.ref,
                         ref_xml=sim.ref_inventory, band=(0.05, 1.0), fit_response="gain",
                         seed=3, progress=False, misfit_shape=a,
                         diagnose=False)     # the fit's own model, not the criticism's improved one
        assert post.summary()["convergence"]["converged"]
        out.append(np.std(post.samples, axis=0))
    return out, post


def test_intervals_widen_only_where_the_model_misses():
    """Where the model fits, every band's factor lies between 1 (the scales
    are at least 1) and the pooled factor at the bands' level-0.001 pooled
    energy, and each sd ratio to the Gaussian between 1 and the square root
    of the largest factor times the Student tail of 2 (a + K) degrees of
    freedom, each end widened by the two sds' Monte Carlo error. Where the
    model misses (a 0.1 s timing offset left out), every band's factor is
    beyond what a fitting band reaches at level 0.001 and every sd ratio
    beyond the largest a fitting record gives."""
    from tests.tolerance import LEVEL

    a = 2.0
    clean = simulate_pair(duration=1800.0, fs=10.0, seed=11, coherence=0.99)
    (gauss, scaled), post = _gain_sds(clean, (np.inf, a))
    ratio = scaled / gauss
    assert post.summary()["adequacy"]["ok"]
    k = post.state.model.band_energy(np.median(post.samples, axis=0)[None])[1]
    factors = np.array(post.meta.misfit_scale["band_variance_factor"])
    big_k = k.sum()
    f_top = band_scale(k * gamma.isf(LEVEL, big_k) / big_k, k, a, None, 0.0)[0]
    assert np.all((factors >= 1.0) & (factors <= f_top)), (factors, f_top)
    mc = Z_001 * np.sqrt(1 / post.summary()["convergence"]["ess_min"])
    tail = np.sqrt(2 * (a + big_k) / (2 * (a + big_k) - 2))
    assert np.all((ratio > 1 - mc) & (ratio < np.sqrt(f_top) * tail * (1 + mc))), (ratio, f_top)
    # a 0.1 s timing offset the model leaves out: misfit growing with frequency
    late = simulate_pair(duration=1800.0, fs=10.0, seed=11, coherence=0.99, timing_offset_s=0.1)
    (gauss, scaled), post = _gain_sds(late, (np.inf, a))
    assert not post.summary()["adequacy"]["ok"]
    factors = np.array(post.meta.misfit_scale["band_variance_factor"])
    fitting = (a + gamma.isf(LEVEL / factors.size, k)) / (a + k)         # 2.33 for k = 9, 5 bands
    assert np.all(factors > fitting), (factors, fitting)
    mc = Z_001 * np.sqrt(1 / post.summary()["convergence"]["ess_min"])
    assert np.all(scaled / gauss * (1 + mc) > np.sqrt(f_top) * tail), (scaled / gauss, f_top)
