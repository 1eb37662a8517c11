"""The per-band noise scale (bayescal.core.model.misfit_scale): the closed form
against numerical integration over the scale, and on simulated pairs:
intervals widen where the model misses (a timing offset the model leaves
out) and stay as they were where it fits."""
import numpy as np
import pytest
from scipy.integrate import quad
from scipy.stats import invgamma

from bayescal.core.model.misfit_scale import band_loglik, band_scale
from bayescal.io.pipeline import calibrate
from bayescal.simulate.pair import simulate_pair


@pytest.mark.parametrize("a,k", [(2.0, 1.0), (2.0, 9.0), (5.0, 4.0)])
def test_closed_form_is_the_integral_over_the_scale(a, k):
    def marginal(q):    # int s^-k exp(-q/s) IG(s; a, a) ds, over u = log s
        f = lambda u: np.exp(-k * u - q * np.exp(-u)) * invgamma.pdf(np.exp(u), a, scale=a) \
            * np.exp(u)
        return quad(f, -10, 15, points=[np.log((q + a) / (k + a + 1))], limit=400,
                    epsabs=0, epsrel=1e-11)[0]
    qs = np.array([0.5 * k, k, 3 * k, 20 * k])
    num = np.log([marginal(q) for q in qs])
    closed = band_loglik(qs[:, None], [k], a)
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


def _gain_sds(sim, shapes):
    out = []
    for a in shapes:
        post = calibrate(sut=sim.sut, sut_xml=sim.sut_inventory, ref=sim.ref, ref_xml=sim.ref_inventory, band=(0.05, 1.0),
                         fit_response="gain", seed=3, progress=False, misfit_shape=a)
        assert post.summary()["convergence"]["converged"]
        out.append(np.std(post.samples, axis=0))
    return out, post


def test_intervals_widen_only_where_the_model_misses():
    clean = simulate_pair(duration=1800.0, fs=10.0, seed=11, coherence=0.99)
    (gauss, scaled), post = _gain_sds(clean, (np.inf, 2.0))
    ratio = scaled / gauss
    assert post.summary()["adequacy"]["ok"]
    assert 0.85 < np.median(ratio) < 1.15 and ratio.max() < 1.3, ratio
    # a 0.1 s timing offset the model leaves out: misfit growing with frequency
    late = simulate_pair(duration=1800.0, fs=10.0, seed=11, coherence=0.99, timing_offset_s=0.1)
    (gauss, scaled), post = _gain_sds(late, (np.inf, 2.0))
    assert not post.summary()["adequacy"]["ok"]
    factors = post.meta["misfit_scale"]["band_variance_factor"]
    assert min(factors) > 2 and max(factors) > 5, factors
    assert np.median(scaled / gauss) > 2.0, scaled / gauss
