"""The pendulum's sampling coordinates, its prior and the prior-sensitivity
test (bayescal.core.response.pendulum), against closed forms."""
from __future__ import annotations

import emcee
import numpy as np
import pytest
from scipy import stats

from bayescal.core.response import pendulum
from tests.tolerance import LEVEL


def test_coordinates_round_trip_and_make_the_inverse_response_linear():
    """(T, h) -> (c0_rel, c1_rel) -> (T, h) is the identity, and H^-1 of the
    pendulum pair, 1 - c0/w^2 - i c1/w, is linear in the coordinates."""
    t, h = pendulum.to_physical(*pendulum.from_physical(97.0, 0.61, 120.0, 0.707), 120.0, 0.707)
    assert (t, h) == pytest.approx((97.0, 0.61), rel=1e-12)
    w = 2 * np.pi * np.array([0.01, 0.1, 1.0])
    w0n, hn = 2 * np.pi / 120.0, 0.707

    def inv_h(c0r, c1r):
        period, damping = pendulum.to_physical(c0r, c1r, 120.0, 0.707)
        w0 = 2 * np.pi / period
        return 1 - w0 ** 2 / w ** 2 - 2j * damping * w0 / w

    a, b = np.array([0.8, 1.3]), np.array([1.2, 0.7])
    assert inv_h(*(0.3 * a + 0.7 * b)) == pytest.approx(0.3 * inv_h(*a) + 0.7 * inv_h(*b))
    assert inv_h(1.0, 1.0) == pytest.approx(1 - w0n ** 2 / w ** 2 - 2j * hn * w0n / w)


def test_prior_sampled_in_the_coefficients_is_the_stated_prior_on_period_and_damping():
    """emcee on the prior alone, in (c0_rel, c1_rel): ln(T/T_nom) and
    ln(h/h_nom) come out normal with the stated sds (3 % and 8 %), checked
    by a Kolmogorov-Smirnov test at the suite's level on thinned draws (the
    prior's Jacobian left out fails it)."""
    tol_t, tol_h = 0.03, 0.08

    def log_prob(theta):
        return pendulum.log_prior(theta[:, 0], theta[:, 1], tol_t, tol_h)

    rng = np.random.default_rng(4)
    sampler = emcee.EnsembleSampler(32, 2, log_prob, vectorize=True)
    sampler.random_state = np.random.RandomState(5).get_state()
    sampler.run_mcmc(1 + 0.01 * rng.standard_normal((32, 2)), 3000, progress=False)
    draws = sampler.get_chain(discard=500, thin=30, flat=True)
    x, y = pendulum.log_deviations(draws[:, 0], draws[:, 1])
    assert stats.kstest(x / tol_t, "norm").pvalue > LEVEL
    assert stats.kstest(y / tol_h, "norm").pvalue > LEVEL


def _gaussian_case(info_c0, info_c1, theta=(1.0, 1.0)):
    fisher = np.diag([info_c0, info_c1])
    return pendulum.prior_sensitivity(fisher, np.array(theta), {"X": (0, 1)}, 0.05, 0.05)["X"]


def test_data_that_fix_only_c1_leave_period_and_damping_to_the_prior():
    """Information on c1 alone (far above the corner): period and damping
    are set by the prior (their sd changes by nearly 2 when the prior's
    width is doubled), damping/period is not."""
    out = _gaussian_case(1e-6, 1e6)
    assert out["period_s"]["set_by_prior"] and out["damping"]["set_by_prior"]
    assert out["period_s"]["width_ratio"] == pytest.approx(2.0, rel=1e-3)
    assert not out["damping_over_period"]["set_by_prior"]
    assert out["damping_over_period"]["width_ratio"] == pytest.approx(1.0, abs=1e-3)


def test_well_fixed_parameters_are_measurements_and_the_rule_has_its_closed_form():
    """Gaussian closed form along c0_rel with c1_rel fixed by the data: the
    prior's precision there is P = 0.5 / sd^2 (c0_rel moves ln T and ln h
    each by -1/2), and halving the prior's width changes the period's sd by
    sqrt((D + 4P) / (D + P)) for data precision D. D = P/2 gives sqrt(3),
    flagged; D = 1e4 P gives about 1, a measurement."""
    prior = pendulum.prior_precision(1.0, 1.0, 0.05, 0.05)[0]
    assert prior[0, 0] == pytest.approx(0.5 / 0.05 ** 2)
    assert prior[1, 1] == pytest.approx(1.0 / 0.05 ** 2)
    p = prior[0, 0]
    weak = _gaussian_case(p / 2, 1e12)["period_s"]
    assert weak["width_ratio"] == pytest.approx(np.sqrt(3.0), rel=1e-3)
    assert weak["set_by_prior"]
    strong = _gaussian_case(1e4 * p, 1e12)
    assert strong["period_s"]["width_ratio"] == pytest.approx(np.sqrt(1.0004 / 1.0001), rel=1e-4)
    assert not any(e["set_by_prior"] for e in strong.values())


def test_a_value_in_the_prior_tail_is_pulled_and_flagged():
    """A posterior median three tolerances from nominal, data carrying 85 %
    of the information on c0 and everything on c1: doubling the prior's width
    moves the period by more than half its sd, so the prior pulls it."""
    c0 = np.exp(-2 * 0.15)            # ln(T/T_nom) = +0.15: three tolerances of 5 %
    prior = pendulum.prior_precision(c0, 1.0, 0.05, 0.05)[0]
    out = _gaussian_case(5.7 * prior[0, 0], 1e9, theta=(c0, np.sqrt(c0)))
    assert out["period_s"]["shift_sd"] > pendulum.SHIFT_SD
    assert out["period_s"]["set_by_prior"]


def _posterior_samples(data_mean, data_sd, tol, n=40000, seed=0):
    """Samples of an exact Gaussian posterior in the log deviations (x, y)
    from nominal: a Gaussian likelihood of each times the log-normal prior
    of sd ``tol``, carried to (c0_rel, c1_rel)."""
    rng = np.random.default_rng(seed)
    prec = 1 / data_sd ** 2 + 1 / tol ** 2
    mean = (np.asarray(data_mean) / data_sd ** 2) / prec
    x, y = (mean[:, None] + rng.standard_normal((2, n)) / np.sqrt(prec[:, None]))
    return np.column_stack([np.exp(-2 * x), np.exp(y - x)])        # c0_rel, c1_rel


@pytest.mark.parametrize("ratio", [0.25, 1.0, 4.0])
def test_reweighted_rule_matches_the_closed_form(ratio):
    """Samples of an exact Gaussian posterior reweighted to the halved and
    doubled prior: the period's sd changes by ``sqrt((D + P/s^2) / (D + P))``
    at the worst of s = 1/2, 2 and its median moves by the closed form's
    shift under the doubled prior (data precision ``D`` = ``ratio`` times
    the prior's ``P``), within the samples' own error; where the doubled
    prior's weights leave too few samples (weak data) the value is flagged,
    as the closed form says it must be."""
    tol = 0.05
    data_sd = tol / np.sqrt(ratio)
    mu = np.array([0.06, -0.03])                      # the data's values, in log units
    samples = _posterior_samples(mu, np.array([data_sd, data_sd]), np.array([tol, tol]))
    got = pendulum.reweighted_sensitivity(samples, {"X": (0, 1)}, tol, tol)["X"]["period_s"]
    d, p = 1 / data_sd ** 2, 1 / tol ** 2
    width = max(max(np.sqrt((d + p / s ** 2) / (d + p)), np.sqrt((d + p) / (d + p / s ** 2)))
                for s in (0.5, 2.0))
    mean = lambda s: (mu[0] * d) / (d + p / s ** 2)   # noqa: E731
    shift = abs(mean(2.0) - mean(1.0)) * np.sqrt(d + p)
    flag = bool(width > pendulum.WIDTH_RATIO or shift > pendulum.SHIFT_SD)
    assert got["set_by_prior"] == flag
    if got.get("beyond_samples"):       # the doubled prior's weights: too few samples left
        assert flag and ratio < 1
        return
    assert got["width_ratio"] == pytest.approx(width, rel=0.05)
    assert got["shift_sd"] == pytest.approx(shift, abs=0.05)


def test_reweighting_beyond_the_samples_sets_by_prior():
    """Data that fix nothing: the doubled prior's weights leave few samples
    effective, and the value is set by the prior whatever the quantiles say."""
    samples = _posterior_samples(np.zeros(2), np.array([10.0, 10.0]), np.array([0.05, 0.05]),
                                 n=4000)
    got = pendulum.reweighted_sensitivity(samples, {"X": (0, 1)}, 0.05, 0.05)["X"]
    assert all(e["set_by_prior"] for e in got.values())
