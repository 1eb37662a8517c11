"""The plug-in noise model's own sampling error (:mod:`bayescal.core.model.plugin`).

1. The weight's formula against a Monte Carlo of its own model: a parameter
   combined over bands by generalised least squares whose noise covariances
   are complex-Wishart estimates of ``nu`` samples; the standardised error's
   variance is ``nu^2 / ((nu - p)^2 - 1)`` when several bands carry it (less,
   down to about 90 % of it, when one band does), and 1 once each band is
   weighted (a bias-only correction, ``(nu - p) / nu``, is not enough).
2. The effective samples of a Welch band against a Monte Carlo of white
   noise through Hann-windowed segments overlapping by 50 % (as the fit
   cuts them, gaps allowed) and by 75 %.
3. Both models carry the weights: the base model with ``p = n_u``, the
   errors-in-variables model with ``p = n_u + n_r``; the weighted whitened
   residual's squared norm is the Gaussian ``-log L``, each band's energy
   weighted once.

Whether the weighted fits' intervals cover on short records is the pair
coverage studies' question (tests/test_coverage.py in the suite, the
studies in validation/studies/ for short records): given 1 and 3, a fit
without the weights fails here.
"""
from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest

from bayescal.core.model import plugin
from bayescal.core.spectra.dof import band_dof
from bayescal.core.spectra.welch import hann
from bayescal.simulate import harness


def _gls_z(rng, nu, p, bands, reps):
    """Standardised errors of a scalar estimated by GLS over ``bands`` bands,
    each with a plug-in covariance from ``nu`` complex samples."""
    z = np.empty(reps)
    for r in range(reps):
        num = den = 0.0
        for _ in range(bands):
            a = rng.normal(size=(p, p)) + 1j * rng.normal(size=(p, p))
            chol = np.linalg.cholesky(a @ a.conj().T / p + np.eye(p))
            m = rng.normal(size=p) + 1j * rng.normal(size=p)
            x = chol @ (rng.normal(size=(p, nu)) + 1j * rng.normal(size=(p, nu))) / np.sqrt(2)
            prec = np.linalg.inv(x @ x.conj().T / nu)
            e = chol @ (rng.normal(size=p) + 1j * rng.normal(size=p)) / np.sqrt(2)
            num += 2 * (m.conj() @ prec @ e).real
            den += 2 * (m.conj() @ prec @ m).real
        z[r] = num / np.sqrt(den)
    return z


@pytest.mark.parametrize("nu, p, bands", [(14, 3, 8), (24, 6, 4)])
def test_weight_matches_the_plug_in_variance(nu, p, bands):
    rng = np.random.default_rng(7)
    z = _gls_z(rng, nu, p, bands=bands, reps=3000)
    w = plugin.band_weights([nu], p)[0]
    predicted = nu ** 2 / ((nu - p) ** 2 - 1)          # 1.63 and 1.78 here
    assert z.var() == pytest.approx(predicted, rel=0.1)
    # weighting each band by w restores the variance (MC sd of var ~ 3-4 %) ...
    assert z.var() * w == pytest.approx(1.0, abs=0.1)
    # ... where correcting the inverse's bias alone leaves it 20 % too small
    assert z.var() * (nu - p) / nu > 1.15


def test_one_band_is_between_the_bias_and_the_many_band_value():
    """With the information in one band the variance is smaller than the
    many-band value (1.46 against 1.63 at nu = 14, p = 3), so the weight is
    on the safe side there; the bias alone (1.27) still falls short."""
    nu, p = 14, 3
    z = _gls_z(np.random.default_rng(7), nu, p, bands=1, reps=3000)
    assert nu / (nu - p) * 1.08 < z.var() < nu ** 2 / ((nu - p) ** 2 - 1)


def test_weight_limits():
    w = plugin.band_weights([500.0, 20.0, 4.0, 1.0], 3)
    assert w[0] == pytest.approx((497.0 ** 2 - 1) / 500.0 ** 2) and w[0] > 0.98
    assert w[1] == pytest.approx((17.0 ** 2 - 1) / 400.0)
    assert w[2] == plugin.MIN_WEIGHT and w[3] == plugin.MIN_WEIGHT


@pytest.mark.parametrize("bins, starts", [(8, [0, 128, 256, 384, 512]),       # 50 % overlap
                                          (3, [0, 128, 256, 384, 512]),
                                          (8, [0, 256, 512, 640]),           # a gap, then overlap
                                          (8, list(range(0, 832, 64)))])     # 75 % overlap
def test_effective_samples_of_a_welch_band(bins, starts):
    """White noise, Hann segments of 256 samples: the band sum of |X|^2 over
    ``bins`` bins and the given segments has relative variance 1 / nu. At
    75 % overlap segments two and three apart overlap too (counting only
    neighbours gave 30.3 where this Monte Carlo gives 29.1)."""
    nperseg, first = 256, 20
    sp = SimpleNamespace(nperseg=nperseg, segment_starts=np.array(starts),
                         bins_per_band=np.array([bins]))
    nu = band_dof(sp)[0]
    shuffled = SimpleNamespace(nperseg=nperseg, bins_per_band=sp.bins_per_band,
                               segment_starts=np.random.default_rng(0).permutation(starts))
    assert band_dof(shuffled)[0] == pytest.approx(nu, rel=1e-12)
    rng = np.random.default_rng(3)
    win = hann(nperseg)
    idx = np.array(starts)[:, None] + np.arange(nperseg)
    totals = []
    for _ in range(8):                                             # 40000 draws
        x = rng.standard_normal((5000, starts[-1] + nperseg))
        f = np.fft.rfft(x[:, idx] * win, axis=2)[:, :, first:first + bins]
        totals.append(np.sum(np.abs(f) ** 2, axis=(1, 2)))
    totals = np.concatenate(totals)
    measured = totals.mean() ** 2 / totals.var()
    assert measured == pytest.approx(nu, rel=0.025)               # MC error ~ 0.8 %
    assert nu < bins * len(starts)                                 # fewer than counted


@pytest.fixture(scope="module")
def pair():
    from bayescal.simulate import simulate_pair
    azs, dips, resp = harness.draw_truth(3001, "gain")
    cu, cr = harness.coherences(0.99, 1.0)
    return simulate_pair(duration=900.0, fs=10, seed=3001, coherence=cu, ref_coherence=cr,
                         sut_azimuth=azs, sut_dip=dips, sut_response=resp,
                         nominal_response=harness.NOMINAL, noise_in_counts=True)


@pytest.mark.parametrize("mode", ["quiet", "estimate", "equal"])
def test_models_carry_the_weights(pair, mode):
    from bayescal.pair.workflow import calibrate
    post = calibrate(sut=pair.sut, sut_xml=pair.sut_inventory, ref=pair.ref, ref_xml=pair.ref_inventory,
                     band=(0.02, 1.0), fit_response="gain", progress=False, ref_noise=mode)
    model = post.state.model
    sp = model.spectra
    p = sp.n_u + (0 if mode == "quiet" else sp.n_r)
    expected = plugin.band_weights(band_dof(sp), p)
    np.testing.assert_allclose(model.noise.weight, expected)
    assert post.meta.plugin_weights == [round(float(v), 4) for v in expected]
    assert 0.5 < expected.min() < expected.max() < 1.0
    # the weighted whitened residual is the weighted Gaussian likelihood
    theta = post.state.theta_ls + 1e-3
    saved, model.misfit_shape = model.misfit_shape, float("inf")
    try:
        ll = model.log_likelihood(theta[None])[0]
        r = model.whitened_residual(theta, model.noise.cholesky())
    finally:
        model.misfit_shape = saved
    assert np.sum(r ** 2) == pytest.approx(-ll, rel=1e-9)
    # ... and that is the unweighted bands' energy weighted once, not twice
    q, _ = model.band_energy(theta[None])
    assert -ll == pytest.approx(np.sum(expected * q[0]), rel=1e-9)
    assert not np.allclose(np.sum(expected * q[0]), np.sum(q[0]), rtol=1e-3)


def test_diagnosis_reports_its_final_models_weights(pair):
    """A diagnosis that ends on another model (here the errors-in-variables
    model after a quiet base fit) reports that model's weights (``p = n_u +
    n_r``), not the base fit's."""
    from bayescal.criticism.diagnose import posterior_of
    from bayescal.pair.workflow import calibrate
    base = calibrate(sut=pair.sut, sut_xml=pair.sut_inventory, ref=pair.ref, ref_xml=pair.ref_inventory,
                     band=(0.02, 1.0), fit_response="gain", progress=False, ref_noise="quiet")
    eiv = calibrate(sut=pair.sut, sut_xml=pair.sut_inventory, ref=pair.ref, ref_xml=pair.ref_inventory,
                    band=(0.02, 1.0), fit_response="gain", progress=False, ref_noise="estimate")
    final = posterior_of(eiv.state.model, eiv.state.theta_ls, np.diag(np.full(eiv.state.model.ndim, 1e-8)),
                         base.meta.to_dict(), base.not_estimable, "gain", mcmc=False, n_laplace=50)
    expected = [round(float(v), 4) for v in eiv.state.model.noise.weight]
    assert final.meta.plugin_weights == expected != base.meta.plugin_weights
