"""The reference's tolerance integrated out with the SUT's prior acting on
the moved samples (``bayescal/core/response/reference_tolerance.py``):
against the closed form of a Gaussian toy, against the target sampled
directly by rejection for a pendulum pair, unchanged where the prior is
flat, and a 360-s SUT beside a 120-s reference end to end."""
from __future__ import annotations

import warnings

import numpy as np
import pytest
from scipy.stats import norm

from bayescal.core.priors import Priors
from bayescal.core.response import pendulum, reference_tolerance as rt
from bayescal.errors import InputWarning
from bayescal.pair.workflow import calibrate
from bayescal.simulate.pair import simulate_pair, velocity_response
from tests.tolerance import Z_001

#: KS critical value at the suite's level (two-sided, asymptotic): sqrt(-ln(LEVEL / 2) / 2).
KS_001 = float(np.sqrt(-np.log(0.001 / 2) / 2))


class _GaussianLogGain:
    """A toy prior: Gaussian in ln g (mean ``mu``, sd ``sd``), period and damping held."""

    free, flat = "gain", False

    def __init__(self, mu, sd):
        self.mu, self.sd = mu, sd

    def log_density(self, rows):
        return -0.5 * ((np.log(rows[:, 2]) - self.mu) / self.sd) ** 2


def _effective(info, n):
    """Effective draws of a resampled set: the pool's Kish number and the
    resampling of ``n`` from it, 1 / (1 / ESS + 1 / n)."""
    return 1.0 / (1.0 / info["effective_draws"] + 1.0 / n)


def test_gaussian_toy_matches_its_closed_form():
    """Prior N(mu0, s0^2), likelihood N(u; z - m, sL^2) and the reference's
    error N(0, tol^2), all in ln g: the fit (reference exact) has precision
    1/s0^2 + 1/sL^2; with the reference's error integrated out the
    posterior is Gaussian with precision 1/s0^2 + 1/(sL^2 + tol^2) and mean
    (mu0/s0^2 + (m + u)/(sL^2 + tol^2)) / precision. The widened samples
    match its mean and sd within Monte Carlo error and pass a KS test
    against it; the moves without the prior's weights (the prior taken as
    flat) give sd hypot(sd_fit, tol) and fail all three."""
    mu0, s0, s_l, tol, m_u, n = np.log(750.0), 0.02, 0.01, 0.05, np.log(750.0) + 0.03, 20_000
    p_fit = 1 / s0 ** 2 + 1 / s_l ** 2
    fit = (mu0 / s0 ** 2 + m_u / s_l ** 2) / p_fit + np.random.default_rng(5).standard_normal(
        n) / np.sqrt(p_fit)
    samples = np.column_stack([np.full(n, 120.0), np.full(n, 0.7), np.exp(fit)])
    p_true = 1 / s0 ** 2 + 1 / (s_l ** 2 + tol ** 2)
    mean, sd = (mu0 / s0 ** 2 + m_u / (s_l ** 2 + tol ** 2)) / p_true, 1 / np.sqrt(p_true)

    def check(prior):
        out, info = rt.widen(samples, (120.0, 0.707), tol, np.random.default_rng(6), prior)
        x = np.log(out[:, 2])
        ne = _effective(info, n)
        ks = np.max(np.abs(np.arange(1, n + 1) / n - norm.cdf(np.sort(x), mean, sd)))
        return (abs(x.mean() - mean) < Z_001 * sd / np.sqrt(ne),
                abs(x.std() / sd - 1) < Z_001 / np.sqrt(2 * ne),
                ks < KS_001 / np.sqrt(ne)), info

    ok, info = check(_GaussianLogGain(mu0, s0))
    assert all(ok), (ok, info)
    assert 0.1 < info["kish_fraction"] < 1          # the weights do work here
    old, _ = check(None)                            # no weights: the moves alone
    assert not any(old)


@pytest.mark.parametrize("fit_tol", [0.05, 0.2])
def test_pendulum_weights_match_the_target_sampled_directly(fit_tol):
    """A 360-s SUT (prior log-normal, 5 %) beside a 120-s reference known
    to 4 %, a likelihood Gaussian in what the data fix, ``(c1_sut - c1_ref,
    q_sut - q_ref)``, half as wide as the SUT's prior: the target, the SUT's
    prior times the likelihood with the reference's error integrated out,
    sampled directly by rejection (SUT draws from its prior, the
    reference's error from its law, accepted with the likelihood); the fit
    by rejection with the reference exact, its prior the stated one or
    (``fit_tol`` 0.2) a wider one, as the fit samples with. The widened
    fit's period and damping quantiles match the target's; without the
    Jacobian of (T, h) -> (c1, q) in the weights (the log-normal density
    alone) they do not, and with the stated prior in place of the sampled
    one they do not or the weights collapse onto a few samples."""
    rng = np.random.default_rng(11)
    nom, ref, tol, ptol, n = (360.0, 0.7), (120.0, 0.707), 0.04, 0.05, 400_000

    def coeffs(t, h):
        w0 = 2 * np.pi / t
        return 2 * h * w0, w0 ** 2 * (1 - 2 * h ** 2)

    c1n, qn = coeffs(*nom)
    c1r, qr = coeffs(*ref)
    s = np.array([c1n * 0.035, 1.6e-5])         # half the prior's spread in (c1, q)
    u_obs = np.array([c1n - c1r, qn - qr]) + np.array([0.5, -0.7]) * s

    def prior_draws(k, tol_=ptol):
        return nom[0] * np.exp(tol_ * rng.standard_normal(k)), nom[1] * np.exp(
            tol_ * rng.standard_normal(k))

    def accepted(t, h, dc1, dq):
        c1, q = coeffs(t, h)
        r = ((c1 - c1r - dc1 - u_obs[0]) / s[0]) ** 2 + ((q - qr - dq - u_obs[1]) / s[1]) ** 2
        return rng.uniform(size=t.size) < np.exp(-0.5 * r)

    t, h = prior_draws(n * int(fit_tol / ptol) ** 2, fit_tol)
    keep = accepted(t, h, 0.0, 0.0)
    fit = np.column_stack([t[keep], h[keep], np.full(keep.sum(), 750.0)])
    t, h = prior_draws(8 * n)
    e = tol * rng.standard_normal((8 * n, 2))
    c1e, qe = coeffs(ref[0] * np.exp(e[:, 0]), ref[1] * np.exp(e[:, 1]))
    dc1, dq = c1e - c1r, qe - qr
    keep = accepted(t, h, dc1, dq)
    target = np.column_stack([t[keep], h[keep]])
    assert fit.shape[0] > 5000 and target.shape[0] > 5000
    prior = rt.SutPrior(free="all", log_gain=(0.0, 20.0), nominal=nom, tolerance=(ptol, ptol))
    sampled = rt.SutPrior(free="all", log_gain=(0.0, 20.0), nominal=nom,
                          tolerance=(fit_tol, fit_tol))

    class NoJacobian(rt.SutPrior):
        def log_density(self, rows):
            x, y = np.log(rows[:, 0] / nom[0]), np.log(rows[:, 1] / nom[1])
            lp = -0.5 * (x / ptol) ** 2 - 0.5 * (y / ptol) ** 2
            return np.where(np.isfinite(lp), lp, -np.inf)

    def quantiles_match(p, q_=sampled):
        out, info = rt.widen(fit, ref, tol, np.random.default_rng(12), p, q_)
        ne = min(_effective(info, fit.shape[0]), target.shape[0])
        ok = []
        for j in (0, 1):
            for q in (0.1, 0.5, 0.9):
                # a quantile's sd: sqrt(q (1 - q) / n) / density, the density from the target
                got, want = np.quantile(out[:, j], q), np.quantile(target[:, j], q)
                dens = 0.02 / np.diff(np.quantile(target[:, j], [q - 0.01, q + 0.01]))[0]
                se = np.sqrt(q * (1 - q) * (1 / ne + 1 / target.shape[0])) / dens
                ok.append(abs(got - want) < Z_001 * se)
        return all(ok), info["effective_draws"]

    right, draws = quantiles_match(prior)
    assert right
    if fit_tol == ptol:
        assert not quantiles_match(NoJacobian(**prior.__dict__))[0]
    else:       # the wrong denominator: off, or its weights collapse onto a few samples
        wrong, few = quantiles_match(prior, prior)
        assert not wrong or few < 0.01 * draws, (wrong, few, draws)


def test_a_flat_prior_moves_each_sample_by_one_draw():
    """Where the SUT's prior is flat in the moved coordinates (its gain
    alone, log-uniform) every weight is 1: the result is each sample moved
    by one draw, as without weights, with the Kish share 1; the held period
    and damping stay where they are."""
    rng = np.random.default_rng(3)
    n, tol = 5000, 0.04
    samples = np.column_stack([np.full(n, 120.0), np.full(n, 0.7),
                               750 * np.exp(0.01 * rng.standard_normal(n))])
    prior = rt.SutPrior(free="gain", log_gain=(np.log(75.0), np.log(7500.0)))
    out, info = rt.widen(samples, (120.0, 0.707), tol, np.random.default_rng(4), prior)
    eps = tol * np.random.default_rng(4).standard_normal((n, 3))
    assert np.array_equal(out[:, 2], samples[:, 2] * np.exp(eps[:, 2]))
    assert np.array_equal(out[:, :2], samples[:, :2])
    assert info["kish_fraction"] == 1.0 and info["draws_per_sample"] == 1
    # the flat prior with period and damping free: moved, still one draw each
    out, _ = rt.widen(samples, (120.0, 0.707), tol, np.random.default_rng(4), None)
    assert np.array_equal(out, rt.moved(samples, (120.0, 0.707), eps))


def test_a_360_s_sut_beside_a_120_s_reference_stays_within_its_prior():
    """A 360-s SUT (truth inside its 5 % prior) beside a 120-s reference
    whose metadata are 2-4 % off, fitted with ``--fit-response all`` and the
    reference's 3.6 % tolerance: each channel's period interval is no wider
    than the prior's (half the 16-84 % range of ln T at most 0.05 plus its
    Monte Carlo error; the moves without the prior's weights give about
    0.25), holds the truth, is flagged as set by the prior, and the fit
    warns that the reference's tolerance is far wider than the SUT's
    prior."""
    truth = ((352.0, 0.718, 788.0), (356.1, 0.709, 748.1), (362.4, 0.730, 738.8))
    sim = simulate_pair(duration=1200.0, fs=5.0, seed=43, coherence=0.99, ref_coherence=0.99,
                        sut_response=truth, nominal_response=(360.0, 0.707, 750.0))
    for ch in sim.ref_inventory[0][0]:
        ch.response = velocity_response(120.0 * 0.979, 0.707 * 0.96, 1500.0 * 1.047,
                                        sample_rate=5.0)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        post = calibrate(ref=sim.ref, ref_xml=sim.ref_inventory, sut=sim.sut,
                         sut_xml=sim.sut_inventory, band=(9 / 360.0, 1.0), fit_response="all",
                         seed=43, progress=False, diagnose=False,
                         priors=Priors(reference_tolerance=0.036))
    # sampled with the reference's error in its prior; the stated prior reported
    assert post.meta.response_prior["period_tolerance"] == 0.05
    assert post.meta.reference_tolerance["sampled_with"]["damping_tolerance"] > 0.3
    said = [str(w.message) for w in caught if issubclass(w.category, InputWarning)]
    assert any("much wider than the SUT's prior" in s for s in said), said
    summary = post.summary()["channels"]
    for k, cid in enumerate(post.channel_ids):
        logt = np.log(post.response[cid][:, 0])
        lo, hi = np.quantile(logt, (0.16, 0.84))
        ne = post.meta.reference_tolerance["effective_draws"][cid]
        assert 0.5 * (hi - lo) < 0.05 * (1 + Z_001 * np.sqrt(pendulum.HALF_WIDTH_VAR / ne))
        assert summary[cid]["response"]["period_s"]["set_by_prior"]
        lo, hi = np.quantile(post.response[cid][:, 0], (0.05, 0.95))
        assert lo <= truth[k][0] <= hi


@pytest.mark.parametrize("sd, flagged", [(0.045, True), (0.01, False)])
def test_the_flag_reweights_the_reported_values_at_their_own_prior(sd, flagged):
    """Reported log period and damping N(0, sd^2) about nominal, the SUT's
    prior 5 %: the prior acts on them, so the halved and doubled prior's
    weights are taken at them, and the reweighted spread is the Gaussian
    closed form: precision 1/sd^2 + (1/s^2 - 1)/0.05^2 for the prior scaled
    by s, so the width ratio is max(sqrt(1 + 3 sd^2/0.05^2), 1/sqrt(1 -
    0.75 sd^2/0.05^2)): 1.85 (the prior sets them, flagged) for sd 0.045,
    1.06 (the data do) for 0.01; within Monte Carlo error."""
    rng = np.random.default_rng(21)
    n, tol, nom = 40_000, 0.05, (360.0, 0.7)
    r = np.column_stack([nom[0] * np.exp(sd * rng.standard_normal(n)),
                         nom[1] * np.exp(sd * rng.standard_normal(n)), np.full(n, 750.0)])
    prior = rt.SutPrior(free="all", log_gain=(0.0, 20.0), nominal=nom, tolerance=(tol, tol))
    got = rt.judged_sensitivity({"X": r}, {"X": prior}, {"X": n})["X"]
    v = (sd / tol) ** 2
    want = max(np.sqrt(1 + 3 * v), 1 / np.sqrt(1 - 0.75 * v))
    for name in ("period_s", "damping"):
        e = got[name]
        assert e["set_by_prior"] == flagged
        assert abs(e["width_ratio"] - want) < Z_001 * want * np.sqrt(
            pendulum.HALF_WIDTH_VAR * 2 / (n * 0.3)), (name, e["width_ratio"], want)


def test_the_sampling_prior_adds_the_reference_error_carried_into_the_sut():
    """The reference's error carried into the SUT's (ln T, ln h) through
    ``d(c1, q)/d(ln T, ln h)`` of each, its variance 1.5 times added to the
    stated prior's: for a SUT with the reference's own nominal values the
    map is the identity, each tolerance hypot(0.05, sqrt(1.5) tol). At
    h = 1/sqrt 2 (q = 0) and a SUT of three times the reference's period,
    the reference's errors (e_T, e_h) move ``q`` by -2 w0r^2 e_h, which the
    SUT's -2 w0s^2 d ln h takes up: d ln h = 9 e_h; and ``c1`` by c1r (e_h -
    e_T) = 3 c1s (e_h - e_T), so d ln T = d ln h - 3 (e_h - e_T) = 6 e_h +
    3 e_T: variances 81 tol^2 and 45 tol^2."""
    tol = 0.036
    same = rt.sampling_tolerances(tol, [((120.0, 0.707), (120.0, 0.707))], 0.05, 0.05)
    assert same == pytest.approx((np.hypot(0.05, np.sqrt(1.5) * tol),) * 2, rel=1e-9)
    t, h = rt.sampling_tolerances(tol, [((360.0, 1 / np.sqrt(2)), (120.0, 1 / np.sqrt(2)))],
                                  0.05, 0.05)
    var_h = 81 * tol ** 2
    var_t = (36 + 9) * tol ** 2
    assert (t, h) == pytest.approx((np.sqrt(0.05 ** 2 + 1.5 * var_t),
                                    np.sqrt(0.05 ** 2 + 1.5 * var_h)), rel=1e-9)
