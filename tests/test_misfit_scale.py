"""The per-band noise scale (bayescal.core.model.misfit_scale): the closed form
against numerical integration over the scale, and on simulated pairs:
intervals widen where the model misses (a timing offset the model leaves
out) and stay as they were where it fits."""
import numpy as np
import pytest
from scipy.integrate import quad
from scipy.stats import invgamma

from bayescal.core.model.misfit_scale import band_loglik, band_scale
from bayescal.pair.workflow import calibrate
from bayescal.simulate.pair import simulate_pair
from tests.tolerance import Z_001


@pytest.mark.parametrize("a,k", [(2.0, 1.0), (2.0, 9.0), (5.0, 4.0)])
def test_closed_form_is_the_integral_over_the_scale(a, k):
    def marginal(q):    # int s^-k exp(-q/s) IG(s; a, a) ds, over u = log s
        f = lambda u: np.exp(-k * u - q * np.exp(-u)) * invgamma.pdf(np.exp(u), a, scale=a) \
            * np.exp(u)
        return quad(f, -10, 15, points=[np.log((q + a) / (k + a + 1))], limit=400,
                    epsabs=0, epsrel=1e-11)[0]
    qs = np.array([0.5 * k, k, 3 * k, 20 * k])
    num = np.log([marginal(q) for q in qs])
    closed = band_loglik(qs[:, None], [k], a, floor=0.0)
    # equal up to a constant independent of q
    assert np.allclose(num - num[0], closed - closed[0], rtol=0, atol=1e-6)


def test_gaussian_limit_and_variance_factor():
    q = np.array([[3.0, 40.0]])
    assert band_loglik(q, [3.0, 3.0], np.inf)[0] == -43.0
    # a very large shape is the Gaussian up to a constant
    d = band_loglik(q, [3.0, 3.0], 1e7) - band_loglik(np.array([[3.0, 3.0]]), [3.0, 3.0], 1e7)
    assert d[0] == pytest.approx(-37.0, rel=1e-4)
    # a band at its expectation keeps its weight; 10x the misfit: (2 + 30) / (2 + 3)
    assert band_scale(np.array([3.0, 30.0]), [3.0, 3.0], 2.0).tolist() == [1.0, 6.4]


@pytest.mark.parametrize("a,k,floor", [(3.0, 4.0, 1.0), (3.0, 9.0, 1.0), (2.0, 1.0, 0.8)])
def test_floored_factor_is_gaussian_below_and_the_marginal_above(a, k, floor):
    """The scale per band with its variance factor at least ``floor``: the
    likelihood's slope in q is min(1 / floor, (a + k) / (a + q)) (the
    Gaussian of variance ``floor`` below q* = floor (a + k) - a, the
    marginal's above), the term continuous at q*, and the variance factor
    the inverse of that slope."""
    q_star = floor * (a + k) - a
    qs = np.array([0.1, 0.5, 0.999, 1.001, 2.0, 10.0, 100.0]) * q_star
    h = 1e-6 * q_star
    slope = -(band_loglik((qs + h)[:, None], [k], a, floor=floor)
              - band_loglik((qs - h)[:, None], [k], a, floor=floor)) / (2 * h)
    expected = np.minimum(1 / floor, (a + k) / (a + qs))
    np.testing.assert_allclose(slope, expected, rtol=1e-6)
    np.testing.assert_allclose(band_scale(qs, [k] * qs.size, a, floor=floor), 1 / expected,
                               rtol=1e-12)
    below = band_loglik(np.array([[q_star * (1 - 1e-9)]]), [k], a, floor=floor)
    above = band_loglik(np.array([[q_star * (1 + 1e-9)]]), [k], a, floor=floor)
    assert below[0] == pytest.approx(-q_star / floor, rel=1e-8)
    assert above[0] == pytest.approx(below[0], rel=1e-8)
    # above q* it is the marginal up to a constant: the marginal's slope
    marg = band_loglik(qs[qs > q_star][:, None], [k], a, floor=0.0)
    got = band_loglik(qs[qs > q_star][:, None], [k], a, floor=floor)
    np.testing.assert_allclose(got - got[0], marg - marg[0], rtol=1e-10, atol=1e-10)


def _gain_sds(sim, shapes):
    out = []
    for a in shapes:
        post = calibrate(sut=sim.sut, sut_xml=sim.sut_inventory, ref=sim.ref, ref_xml=sim.ref_inventory, band=(0.05, 1.0),
                         fit_response="gain", seed=3, progress=False, misfit_shape=a,
                         diagnose=False)     # the fit's own model, not the criticism's improved one
        assert post.summary()["convergence"]["converged"]
        out.append(np.std(post.samples, axis=0))
    return out, post


def test_intervals_widen_only_where_the_model_misses():
    clean = simulate_pair(duration=1800.0, fs=10.0, seed=11, coherence=0.99)
    """Where the model fits, band b's variance factor s_b = (a + q_b) / (a + k_b)
    scatters about 1 with relative sd sqrt(k_b) / (a + k_b) (q_b is
    Gamma(k_b, 1)); a parameter's sd ratio is about the information-weighted
    mean of 1 / s_b to the power -1/2, so it scatters about 1 with sd
    0.5 sqrt(k) / (a + k) / sqrt(B_eff), B_eff = (sum I_b)^2 / sum I_b^2 the
    bands informing it: every ratio within the Bonferroni bound of the
    parameters at level 0.001 of that, plus the two sds' Monte Carlo error.
    Where the model misses (every band's factor beyond what a fitting band
    reaches at level 0.001), each ratio is at least sqrt(min s_b): the
    precision sum_b I_b / s_b is at most sum_b I_b / min s_b, and the
    curvature the marginal's own shape removes only widens further."""
    from scipy.stats import gamma, norm

    from bayescal.core.fit.run import least_squares_fit
    from tests.closed_forms import band_derivatives
    from tests.tolerance import LEVEL

    def band_info(post):
        th, cov = least_squares_fit(post.state.model, np.median(post.samples, axis=0))
        hess = band_derivatives(post.state.model, th, 0.05 * np.sqrt(np.diag(cov)))[1]
        q, k = post.state.model.band_energy(th[None])
        return np.einsum("iib->ib", hess), q[0], k

    a = 2.0
    (gauss, scaled), post = _gain_sds(clean, (np.inf, a))
    ratio = scaled / gauss
    assert post.summary()["adequacy"]["ok"]
    info, q, k = band_info(post)
    b_eff = info.sum(axis=1) ** 2 / np.sum(info ** 2, axis=1)
    z = norm.isf(LEVEL / (2 * ratio.size))
    mc = np.sqrt(1 / post.summary()["convergence"]["ess_min"])      # two sds, 1 / sqrt(2 ESS) each
    tol = z * np.hypot(0.5 * np.sqrt(k.max()) / (a + k.max()) / np.sqrt(b_eff), mc)
    assert np.all(np.abs(ratio - 1) < tol), (ratio, tol)
    # a 0.1 s timing offset the model leaves out: misfit growing with frequency
    late = simulate_pair(duration=1800.0, fs=10.0, seed=11, coherence=0.99, timing_offset_s=0.1)
    (gauss, scaled), post = _gain_sds(late, (np.inf, a))
    assert not post.summary()["adequacy"]["ok"]
    factors = np.array(post.meta.misfit_scale["band_variance_factor"])
    k = post.state.model.band_energy(np.median(post.samples, axis=0)[None])[1]
    fitting = (a + gamma.isf(LEVEL / factors.size, k)) / (a + k)         # 2.33 for k = 9, 5 bands
    assert np.all(factors > fitting), (factors, fitting)
    mc = np.sqrt(1 / post.summary()["convergence"]["ess_min"])
    assert np.all(scaled / gauss > np.sqrt(factors.min()) * (1 - Z_001 * mc)), scaled / gauss
