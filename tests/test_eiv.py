"""Both sensors noisy (errors in variables): the statistic's Wishart
covariance against Monte Carlo, and the bias of the reference-quiet model
beside the errors-in-variables model on pairs whose reference is as noisy as
the SUT (self-noise white in counts, the same on every channel)."""
from __future__ import annotations

import numpy as np
import pytest
from scipy.stats import norm

from bayescal.core.model import refnoise
from bayescal.core.fit.run import build_model, least_squares_fit
from bayescal.core.spectra.welch import cross_spectra
from bayescal.io.align import align
from bayescal.simulate import simulate_pair
from tests.tolerance import LEVEL, Z_001


def test_wishart_covariance_of_the_statistic_matches_monte_carlo():
    rng = np.random.default_rng(0)
    nu, nr = 2, 2
    n = nu + nr
    t = np.array([[0.9, 0.3], [-0.2, 1.1]])
    a = rng.standard_normal((n, n)) + 1j * rng.standard_normal((n, n))
    c = a @ a.conj().T / n
    k = 40
    a0, b0, _ = refnoise.selectors(nu, nr, t)
    terms = [(a0, b0)] + refnoise.noise_terms(t, np.array([0, 1]), np.array([0.7, 1.3]))
    lc = np.linalg.cholesky(c)
    xs = []
    for _ in range(6000):
        z = lc @ ((rng.standard_normal((n, k)) + 1j * rng.standard_normal((n, k))) / np.sqrt(2))
        s = z @ z.conj().T
        xs.append(refnoise.as_real(sum(p @ s @ q for p, q in terms)))
    x = np.array(xs)
    emp = np.cov(x.T)
    theory = refnoise.real_covariance(terms, c, k)
    # the pseudo-covariance matters: Re and Im parts have different variances
    assert not np.allclose(np.diag(theory)[:4], np.diag(theory)[4:], rtol=0.05)
    # each element of the sample covariance is a mean of the N products
    # (x_i - m_i)(x_j - m_j): its Monte Carlo error is their sd over sqrt(N);
    # the d (d + 1) / 2 distinct elements share the level 0.001 (Bonferroni)
    d = x.shape[1]
    dev = x - x.mean(axis=0)
    se = np.std(dev[:, :, None] * dev[:, None, :], axis=0) / np.sqrt(len(x))
    z = float(norm.isf(LEVEL / (d * (d + 1))))
    assert np.all(np.abs(emp - theory) < z * se), np.max(np.abs(emp - theory) / se)


def _gain_errors(mode, seed, coherence=0.9, ref_coherence=0.9):
    """Relative gain errors and their standard deviations (least squares)."""
    gains = 750.0 * (1 + np.random.default_rng(seed).uniform(-0.03, 0.03, 3))
    sim = simulate_pair(duration=3600, fs=10, seed=seed, coherence=coherence,
                        ref_coherence=ref_coherence, noise_in_counts=True,
                        sut_azimuth=(20.0, 110.0, 0.0),
                        sut_response=tuple((30.0, 0.707, g) for g in gains))
    s, r, fs, _ = align(sim.sut, sim.sut_inventory, sim.ref, sim.ref_inventory)
    sp = cross_spectra(s.data, r.data, fs, s.response_fn(), r.response_fn(), (0.02, 1.0),
                       sut_ids=s.ids, ref_ids=r.ids)
    setup = build_model(sp, r.vectors, s.vectors, s.families(), "gain", ref_noise=mode)
    theta, cov = least_squares_fit(setup.model, setup.theta0)
    gi = [i for i, name in enumerate(setup.model.names) if name.endswith("log_gain")]
    err = np.exp(theta[gi]) / gains - 1.0
    sd = np.sqrt(np.diag(cov)[gi])
    return err, np.exp(theta[gi]) / gains * sd, cov[np.ix_(gi, gi)] / np.outer(sd, sd)


@pytest.mark.parametrize("coherence,ref_coherence", [(0.9, 0.9), (0.99, 0.908)])
def test_noisy_reference_quiet_model_biased_estimate_mode_not(coherence, ref_coherence):
    """Reference as noisy as the SUT, and ten times noisier: the base model's
    gains are diluted far outside its intervals; mode 'estimate' is within
    its own (seeded pairs, random gains off the metadata by up to 3 %)."""
    quiet_z, est_z, var_sum = [], [], 0.0
    for seed in (11, 12, 13):
        e, sd, _ = _gain_errors("quiet", seed, coherence, ref_coherence)
        quiet_z.extend(e / sd)
        e, sd, corr = _gain_errors("estimate", seed, coherence, ref_coherence)
        est_z.extend(e / sd)
        var_sum += corr.sum()
    # the mean of the nine standardised errors: pairs are independent, the
    # three gains of one pair correlated as the least-squares covariance says
    # (sum of its correlations), so its sd is sqrt(sum corr) / 9
    sd_mean = np.sqrt(var_sum) / 9
    # the quiet model is biased: its mean beyond the level-0.001 band below
    assert np.mean(quiet_z) < -Z_001 * sd_mean
    # the estimate mode is not: inside the band, two-sided level 0.001
    assert abs(np.mean(est_z)) < Z_001 * sd_mean, (np.mean(est_z), sd_mean)
    # and no single gain beyond the Bonferroni bound of nine at level 0.001
    assert np.max(np.abs(est_z)) < norm.isf(LEVEL / 18)


def test_gain_error_scales_with_the_noise_without_a_drift():
    """Noise-free reference, the same seeded SUT noise at coherence 0.9 and
    0.999 (the simulator draws the same normals, scaled): the estimator is
    linear in the noise, so the standardised errors agree. With the plug-in
    noise held in ground units instead of the SUT's counts
    (core/model/noisescale.py) the low-coherence fit drifted high by about
    ``dim * sd``: +0.48 on these seeds (+0.55 in mode estimate with equal
    noise, whose profiled noise makes it less linear: -0.39 after the fix,
    hence not tested this way)."""
    drift = []
    for seed in (100, 101):
        lo, sd_lo, _ = _gain_errors("quiet", seed, 0.9, 0.99999)
        hi, sd_hi, _ = _gain_errors("quiet", seed, 0.999, 0.99999)
        drift.extend(lo / sd_lo - hi / sd_hi)
    # a regression bound, not a derived tolerance: 0.2 is under half the
    # +0.48 the plug-in noise in ground units gave; the correct estimator's
    # own second-order drift has no closed form here (it is not the
    # (1 + err) factor of the reported sd, |z err| < 0.05 on these seeds)
    assert abs(np.mean(drift)) < 0.2


def test_residual_rows_are_compared_in_the_counts_of_the_plugin_point():
    """Row i of the residual times |rho_i(a0)| / |rho_i(a)|: a gain 2 % above
    the plug-in point's multiplies that SUT row by 1.02 exactly (its noise in ground units is 1.02 times smaller)."""
    from bayescal.core.model import noisescale
    ratio = np.ones((1, 2, 5), complex)
    ratio[0, 1] /= 1.02                          # H_nom / H: gain 2 % higher
    r = np.ones((1, 1, 4, 2, 3))
    out = noisescale.rescale_rows(r, np.ones((2, 4)), ratio, np.full((5, 4), 0.2), [0, 1])
    assert np.allclose(out[0, 0, :, 0], 1.0) and np.allclose(out[0, 0, :, 1], 1.02)
    assert noisescale.rescale_rows(r, None, ratio, np.full((5, 4), 0.2), [1]) is r


def _estimate_model(sim, band=(0.02, 1.0)):
    """The errors-in-variables model (gains free) of a simulated pair."""
    s, r, fs, _ = align(sim.sut, sim.sut_inventory, sim.ref, sim.ref_inventory)
    sp = cross_spectra(s.data, r.data, fs, s.response_fn(), r.response_fn(), band,
                       sut_ids=s.ids, ref_ids=r.ids)
    return build_model(sp, r.vectors, s.vectors, s.families(), "gain", ref_noise="estimate")


def test_eiv_model_in_model_criticism_and_one_channel_refusal():
    """A diagnosis of an errors-in-variables fit scores orientation findings
    under its own model (this crashed once), and a one-channel horizontal
    reference, which has no errors-in-variables model, is refused."""
    from bayescal import calibrate
    from bayescal.core.model.eiv import EIVModel
    from bayescal.errors import FitError
    from bayescal.criticism.search import held_orientation_loglik

    sim = simulate_pair(duration=3600, fs=10, seed=2, coherence=0.95, ref_coherence=0.95,
                        noise_in_counts=True)
    setup = _estimate_model(sim)
    assert isinstance(setup.model, EIVModel)
    theta, _ = least_squares_fit(setup.model, setup.theta0)
    vecs = setup.model.unpack(theta[None])[0][0]
    at_fit = held_orientation_loglik(setup.model, theta, vecs)
    flipped = vecs.copy()
    flipped[1] *= -1
    # the fitted axes explain the data far better than a reversed channel
    assert at_fit - held_orientation_loglik(setup.model, theta, flipped) > 100
    with pytest.raises(FitError, match="one-channel"):
        calibrate(sut=sim.sut, sut_xml=sim.sut_inventory, ref=sim.ref.select(channel="BHN"), ref_xml=sim.ref_inventory,
                  band=(0.02, 1.0), progress=False, ref_noise="estimate")


def test_recommended_reference_noise_mode_by_channel_count():
    """Pairs with two or more channels a side get the errors-in-variables
    mode; a one-channel pair cannot separate the noise and stays quiet."""
    assert refnoise.recommended_mode(3, 3) == refnoise.RECOMMENDED == "estimate"
    assert refnoise.recommended_mode(2, 2) == "estimate"
    assert refnoise.recommended_mode(1, 1) == "quiet"
    assert refnoise.recommended_mode(1, 3) == "quiet"


def test_default_mode_and_gain_separation_note(capsys):
    """``calibrate`` without ``ref_noise`` uses the recommended mode (3+3:
    estimate; 1+1: quiet) and says so; over a band under a decade wide the
    reference's noise is poorly separated from the gains and the output says
    that too, while each gain stays within 3.29 posterior sd of the truth."""
    from bayescal import calibrate
    from bayescal.cli.fit import print_summary
    from bayescal.core.checks.separation import WIDE_RATIO

    sim = simulate_pair(duration=3600.0, fs=10.0, seed=11, coherence=0.99,
                        sut_azimuth=(3.0, 93.0, 0.0), sut_dip=(0.0, 0.5, -89.5),
                        sut_response=((30.0, 0.707, 750.0 * 1.02),) * 3)
    post = calibrate(sut=sim.sut, sut_xml=sim.sut_inventory, ref=sim.ref, ref_xml=sim.ref_inventory, band=(0.3, 2.0),
                     progress=False, min_ess=200, n_tau=20)
    rn = post.meta.reference_noise
    assert rn["mode"] == "estimate" and rn["chosen_by"] == "default"
    ratios = rn["separation"]["gain_sd_ratio"]
    # within the noise the spectra admit (non-negative, at most the incoherent
    # power) the horizontals' gains may separate; the vertical's do not here
    assert max(ratios.values()) > WIDE_RATIO and "poorly separated" in rn["separation"]["note"]
    summary = post.summary()
    for cid, e in summary["channels"].items():
        rel = e["response"]["relative_gain"]
        sd = (rel["ci68"][1] - rel["ci68"][0]) / 2
        assert abs(rel["median"] - 1.02) < 3.29 * sd, (cid, rel)     # level 0.001 each
    print_summary(summary)
    out = capsys.readouterr().out
    assert "reference noise: in this band (0.3-2 Hz)" in out
    assert "reference noise: estimate (the reference's self-noise estimated" in out
    assert "the default for this pair)" in out
    one = calibrate(sut=sim.sut.select(channel="BHZ"), sut_xml=sim.sut_inventory,
                    ref=sim.ref.select(channel="BHZ"), ref_xml=sim.ref_inventory, band=(0.05, 1.0),
                    progress=False, min_ess=200, n_tau=20)
    assert one.meta.reference_noise["mode"] == "quiet"
    assert one.meta.reference_noise["chosen_by"] == "default"


def test_profiled_noise_columns_match_the_dense_design():
    """:func:`refnoise.profile_columns` (one Gram matrix per band) gives the
    dense least-squares solution with the full ``2 n_r``-column design."""
    rng = np.random.default_rng(5)
    nw, nb, n2m, nr = 4, 7, 18, 3
    x0 = rng.standard_normal((nw, nb, n2m))
    u = rng.standard_normal((nw, nb, n2m, nr))
    shapes = rng.random((nb, nr, 2))
    a = rng.standard_normal((nb, n2m, n2m))
    w = a @ np.swapaxes(a, -1, -2)
    g = (u[..., :, None] * shapes[None, :, None, :, :]).reshape(nw, nb, n2m, 2 * nr)
    h = np.einsum("wbip,bij,wbjq->wpq", g, w, g)
    grad = np.einsum("wbip,bij,wbj->wp", g, w, x0)
    want = -np.linalg.solve(h, grad[..., None])[..., 0]
    c, term, q = refnoise.profile_columns(x0, u, shapes, w)
    np.testing.assert_allclose(c.reshape(nw, -1), want, rtol=1e-6)
    np.testing.assert_allclose(term, np.einsum("wbip,wp->wbi", g, want), rtol=1e-6, atol=1e-9)
    x = x0 + term
    np.testing.assert_allclose(q, np.einsum("wbi,bij,wbj->wb", x, w, x), rtol=1e-8)


def test_gain_separation_compares_like_with_like():
    """The separation ratio (core/checks/separation.py) compares the
    errors-in-variables gains' sd with the quiet model's under the same band
    weights: on a 15-minute record, where the weights of a 6x6 plug-in and a
    3x3 one differ most, it is what it is with the weights off on both sides
    (measured within 0.3 %); with each model's own weights it read 10 % or more
    higher on two such pairs, 0.78 against 0.64 on one channel here."""
    from bayescal.core.model.jacobian import forward_jacobian
    from bayescal.core.checks.separation import gain_separation

    setup = _estimate_model(simulate_pair(duration=900.0, fs=10.0, seed=1, coherence=0.99,
                                          ref_coherence=0.99, noise_in_counts=True))
    model = setup.model
    theta, _ = least_squares_fit(model, setup.theta0)
    model.estimate_noise(theta)
    assert np.ptp(model.noise.weight) > 0.2          # short record: the weights matter here

    def information_cov():
        jac = forward_jacobian(model, matmul=True)(theta, model.noise.cholesky())
        return np.linalg.inv(2.0 * jac.T @ jac)

    weighted = gain_separation(model, theta, information_cov())["gain_sd_ratio"]
    model.noise.weight = None
    plain = gain_separation(model, theta, information_cov())["gain_sd_ratio"]
    for cid in plain:
        assert weighted[cid] == pytest.approx(plain[cid], rel=0.02), cid


def test_walker_blocks_give_each_walker_its_own_value():
    """The profiled statistic is evaluated a block of walkers at a time
    (memory): every walker's energy, statistic and noise coefficients equal
    those of that walker evaluated alone, walkers far enough from the fit
    that the noise range binds included."""
    from bayescal.core.model import eiv

    # a quiet reference: walkers off the fit put its noise at the range's ends
    sim = simulate_pair(duration=1800, fs=10, seed=3, coherence=0.95, ref_coherence=0.999,
                        noise_in_counts=True)
    setup = _estimate_model(sim)
    model = setup.model
    theta, _ = least_squares_fit(model, setup.theta0)
    rng = np.random.default_rng(1)
    n = 2 * eiv.WALKER_BLOCK + 7
    walkers = theta + rng.normal(0.0, 0.02, (n, theta.size)) * rng.choice([0.01, 1.0], (n, 1))
    q, dof = model.band_energy(walkers)
    x, coef = model.statistic(walkers)
    alone = [(model.band_energy(w[None])[0][0], *(v[0] for v in model.statistic(w[None])))
             for w in walkers]
    assert q.shape == (n, model.spectra.n_bands) and coef.shape[0] == n
    np.testing.assert_allclose(q, [a[0] for a in alone], rtol=1e-12)
    np.testing.assert_allclose(x, [a[1] for a in alone], rtol=1e-12, atol=1e-12 * np.abs(x).max())
    np.testing.assert_allclose(coef, [a[2] for a in alone], rtol=1e-12,
                               atol=1e-12 * np.abs(coef).max())
    # the spread walkers reach the noise range's ends, the close ones do not
    on_end = [model.on_bound(w) for w in walkers]
    assert any(on_end) and not all(on_end)
