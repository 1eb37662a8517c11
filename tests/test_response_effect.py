"""The response effect (bayescal.criticism.effects.corner.SutCorner): its
factor against the two-pole family's closed form, its null on flat and
two-pole metadata, its physical values, the Laplace evidence that chooses
between the sensor's stated prior and the wide one, and the relative
response of a fitted state (bayescal.criticism.relative_response)."""
from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest

from bayescal.core.response import TwoPoleFamily
from bayescal.core.response.family import ScaleFamily
from bayescal.criticism.effects import SutCorner

F = np.array([0.02, 0.05, 0.2, 1.0, 7.0])
FMIN = 0.03


def _ab(period, damping):
    w0, w1 = 2 * np.pi / period, 2 * np.pi * FMIN
    return 2 * damping * w0 / w1, (w0 / w1) ** 2


def test_null_is_the_metadata_and_the_factor_the_two_pole_closed_form():
    """On two-pole metadata (120 s, 0.707) the factor is 1 at its null and,
    at the coordinates of a 40 s, 0.3 pendulum, the inverse of
    TwoPoleFamily.ratio (H(T, h) / H_nom at the same gain, unit amplitude
    ratio at the normalisation frequency)."""
    fam = TwoPoleFamily(period_s=120.0, damping=0.707, gain=1500.0, norm_freq=1.0,
                        gain_units="counts/(m/s)")
    e = SutCorner([0], [fam], ["XX.S..BHZ"], FMIN)
    np.testing.assert_allclose(e.null, _ab(120.0, 0.707), rtol=1e-12)
    np.testing.assert_allclose(e.factor(F, e.null[None]), 1.0, atol=1e-12)
    p = np.array([_ab(40.0, 0.3)])
    want = 1.0 / fam.ratio(F, 40.0, 0.3, 1500.0)[0]
    np.testing.assert_allclose(e.factor(F, p)[0, 0], want, rtol=1e-10)


def test_flat_metadata_have_no_corner_at_their_null():
    """On flat metadata the null is (0, 0) and the factor at a 120 s,
    0.707 pendulum undoes that pendulum: ``D(s) / s^2``, unit amplitude at
    the normalisation frequency."""
    fam = ScaleFamily(gain=1.0, norm_freq=1.0, gain_units="counts/(m/s)")
    e = SutCorner([0], [fam], ["XX.S..BHZ"], FMIN)
    assert e.flat == [True] and np.all(e.null == 0)
    np.testing.assert_allclose(e.factor(F, np.zeros((1, 2))), 1.0, atol=1e-15)
    s, sn = 2j * np.pi * F, 2j * np.pi
    w0 = 2 * np.pi / 120.0
    d = lambda x: x * x + 2 * 0.707 * w0 * x + w0 * w0      # noqa: E731
    want = d(s) / s ** 2 * abs(sn ** 2) / abs(d(sn))
    np.testing.assert_allclose(e.factor(F, np.array([_ab(120.0, 0.707)]))[0, 0], want,
                               rtol=1e-10)
    phys = e.physical(np.array([_ab(120.0, 0.707)]))
    assert phys["period_s:XX.S..BHZ"][0] == pytest.approx(120.0)
    assert phys["damping:XX.S..BHZ"][0] == pytest.approx(0.707)
    assert phys["damping_over_period:XX.S..BHZ"][0] == pytest.approx(0.707 / 120.0)
    # a draw without a corner (b < 0): no period, the natural frequency 0
    phys = e.physical(np.array([[0.1, -0.01], [0.1, 0.2]]))
    assert "period_s:XX.S..BHZ" not in phys and phys["corner_hz:XX.S..BHZ"][0] == 0.0


def test_the_box_prior_is_a_normalised_density():
    """Uniform over its box: the density integrates to 1 (its log is minus
    the log of the box's area), -inf outside."""
    fam = ScaleFamily(gain=1.0, norm_freq=1.0, gain_units="counts/(m/s)")
    e = SutCorner([0], [fam], ["c"], FMIN)
    hw = e.half_width
    inside = e.log_prior_density(np.array([[0.0, 0.0]]))[0]
    assert inside == pytest.approx(-np.log(4 * hw[0, 0] * hw[0, 1]))
    assert e.log_prior(np.array([[hw[0, 0] * 1.01, 0.0]]))[0] == -np.inf


def test_laplace_evidence_of_a_gaussian_is_exact():
    """For a likelihood exactly Gaussian in the effect's parameters the
    Laplace evidence is exact: with a flat prior of density ``1 / V`` over
    a box much wider than the posterior (sd ``s`` per parameter, ``k`` of
    them), the evidence gain is ``dlogL + k/2 ln(2 pi) + sum ln s - ln V``."""
    from bayescal.criticism.prior_choice import log_evidence_gain

    fam = ScaleFamily(gain=1.0, norm_freq=1.0, gain_units="counts/(m/s)")
    e = SutCorner([0], [fam], ["c"], FMIN)
    sd = np.array([0.01, 0.3])
    cov = np.diag(np.r_[1.0, sd ** 2])
    model = SimpleNamespace(effects=[e], effect_slices=[slice(1, 3)])
    got = log_evidence_gain((model, np.array([0.0, 0.1, 0.5]), cov), {"delta_loglik": 12.5}, 0)
    area = 4 * e.half_width[0, 0] * e.half_width[0, 1]
    assert got == pytest.approx(12.5 + np.log(2 * np.pi) + np.log(sd).sum() - np.log(area))


def test_relative_response_of_a_state_is_its_factors_inverse():
    """A state whose model holds a gain 0.8 of the metadata's and the
    corner of a 40 s, 0.3 pendulum on flat metadata: ``H / H_meta`` is 0.8
    times that pendulum's high-pass ``s^2 / D(s)``, unit amplitude at 1 Hz;
    a timing offset of 2 ms is its delay when asked for, left out when not."""
    from bayescal.criticism import effects as catalogue
    from bayescal.criticism.fitted_response import relative_response

    fam = ScaleFamily(gain=1.0, norm_freq=1.0, gain_units="counts/(m/s)")
    corner = SutCorner([0], [fam], ["c"], FMIN)
    timing = catalogue.TimingOffset([0])
    block = SimpleNamespace(free="gain", family=fam)
    model = SimpleNamespace(blocks=[block], slices=[(slice(0, 0), slice(0, 1))],
                            effects=[corner, timing], effect_slices=[slice(1, 3), slice(3, 4)])
    theta = np.r_[np.log(0.8), _ab(40.0, 0.3), 0.002][None]
    state = SimpleNamespace(model=model, full_samples=theta, theta_ls=None)
    s, sn, w0 = 2j * np.pi * F, 2j * np.pi, 2 * np.pi / 40.0
    d = lambda x: x * x + 2 * 0.3 * w0 * x + w0 * w0      # noqa: E731
    want = 0.8 * s ** 2 / d(s) * abs(d(sn)) / abs(sn ** 2)
    np.testing.assert_allclose(relative_response(state, F, timing=False)[0, 0], want, rtol=1e-10)
    np.testing.assert_allclose(relative_response(state, F)[0, 0],
                               want * np.exp(-2j * np.pi * F * 0.002), rtol=1e-10)


def test_prior_conflict_is_the_prior_predictive_chi_square():
    """Box's prior-predictive test of the stated prior (5 % on period and
    damping) at the wide corner's point: the metadata's own coefficients
    give chi2 0; a damping 30 % up at the same period, measured exactly
    (zero likelihood covariance), gives ``0.3^2 / damping_tol^2 = 36`` on
    2 degrees of freedom (the period's tolerance drops out), and half that
    when the likelihood's covariance equals the prior's."""
    from scipy.stats import chi2

    fam = TwoPoleFamily(period_s=120.0, damping=0.707, gain=1500.0, norm_freq=1.0,
                        gain_units="counts/(m/s)")
    e = SutCorner([0], [fam], ["c"], FMIN)
    zero = np.zeros((2, 2))
    assert e.prior_conflict(e.null, zero, (0.05, 0.05))["chi2"] == pytest.approx(0.0, abs=1e-12)
    a, b = _ab(120.0, 0.707)
    p = np.array([1.3 * a, b])
    got = e.prior_conflict(p, zero, (0.05, 0.05))
    assert got["chi2"] == pytest.approx(36.0, rel=1e-9) and got["dof"] == 2
    assert got["p_value"] == pytest.approx(chi2.sf(36.0, 2), rel=1e-9)
    jac = np.array([[-a, a], [-2 * b, 0.0]])
    prior = jac @ np.diag([0.05 ** 2, 0.05 ** 2]) @ jac.T
    assert e.prior_conflict(p, prior, (0.05, 0.05))["chi2"] == pytest.approx(18.0, rel=1e-9)
    flat = SutCorner([0], [ScaleFamily(gain=1.0, norm_freq=1.0, gain_units="counts/(m/s)")],
                     ["c"], FMIN)
    assert flat.prior_conflict(np.zeros(2), zero, (0.05, 0.05)) is None


def test_a_prior_the_data_conflict_with_gives_way_to_the_wide_corner():
    """Both pass the BIC: the stated prior's larger evidence chooses it
    unless the wide corner's prior-data conflict test rejects that prior;
    a wide corner failing its evidence gate is kept on a conflict only."""
    from bayescal.criticism.prior_choice import by_evidence

    def entries(conflict, corner_evidence=400.0):
        return [{"effect": "response_parameters", "delta_bic": 900.0, "log_evidence_gain": 437.0},
                {"effect": "sut_corner", "delta_bic": 890.0, "log_evidence_gain": corner_evidence,
                 "prior_conflict": {"conflict": conflict}},
                {"effect": "timing_offset", "delta_bic": 3.0}]

    assert [t["effect"] for t in by_evidence(entries(False), 10.0)] == [
        "response_parameters", "timing_offset"]
    assert [t["effect"] for t in by_evidence(entries(True), 10.0)] == ["sut_corner", "timing_offset"]
    assert [t["effect"] for t in by_evidence(entries(False, 2.0), 10.0)] == [
        "response_parameters", "timing_offset"]
    assert [t["effect"] for t in by_evidence(entries(True, 2.0), 10.0)] == [
        "sut_corner", "timing_offset"]


def test_sut_response_is_the_pendulum_of_the_coordinates():
    """What the corrected StationXML writes: on two-pole metadata at the
    coordinates of a 40 s, 0.3 pendulum, that pendulum (period, damping);
    on flat metadata at a 120 s, 0.707 one, a stage with two zeros at the
    origin and the poles ``-h w0 +- i w0 sqrt(1 - h^2)``."""
    fam = TwoPoleFamily(period_s=120.0, damping=0.707, gain=1500.0, norm_freq=1.0,
                        gain_units="counts/(m/s)")
    e = SutCorner([0], [fam], ["c"], FMIN)
    got = e.sut_response(np.array(_ab(40.0, 0.3)), 0)
    assert got["pendulum"] == pytest.approx((40.0, 0.3)) and not got["poles"]
    flat = SutCorner([0], [ScaleFamily(gain=1.0, norm_freq=1.0, gain_units="counts/(m/s)")],
                     ["c"], FMIN)
    got = flat.sut_response(np.array(_ab(120.0, 0.707)), 0)
    w0, h = 2 * np.pi / 120.0, 0.707
    want = -h * w0 + 1j * w0 * np.sqrt(1 - h * h)
    assert got["pendulum"] is None and np.allclose(got["zeros"], 0.0)
    np.testing.assert_allclose(sorted(got["poles"], key=np.imag), [np.conj(want), want],
                               rtol=1e-9)


def test_unstable_corner_is_written_stable():
    """A corner whose fitted coefficients put a pole in the right
    half-plane (negative damping, ``a < 0``, or negative restoring force,
    ``b < 0``: inside the wide box, but no sensor's response) is written
    with no pole in the right half-plane: a negative ``b`` at zero (a pole
    at the origin), a negative ``a`` mirrored (``|a|``: the denominator's
    amplitude ``|D(i w)|`` unchanged at every frequency); the label says
    which, and a stable corner beside it is written as fitted."""
    from bayescal.io.relative_response import effect_changes

    flat = ScaleFamily(gain=1.0, norm_freq=1.0, gain_units="counts/(m/s)")
    e = SutCorner([0, 1], [flat, flat], ["XX.S..BH1", "XX.S..BH2"], FMIN)
    a, b = _ab(120.0, 0.707)
    w1 = 2 * np.pi * FMIN
    s = 2j * np.pi * np.geomspace(1e-3, 10.0, 9)
    for bad, want in (((-a, b), (a, b)), ((a, -b), (a, 0.0)), ((-a, -b), (a, 0.0))):
        state = SimpleNamespace(
            model=SimpleNamespace(effects=[e], effect_slices=[slice(0, 4)],
                                  blocks=[SimpleNamespace(channel_id=c) for c in e.channel_ids]),
            full_samples=np.tile([*bad, a, b], (5, 1)))
        changes, missing = effect_changes(state)
        assert not missing
        (got,), (good,) = changes["XX.S..BH1"], changes["XX.S..BH2"]
        np.testing.assert_allclose(np.sort_complex(np.asarray(got["poles"])),
                                   np.sort_complex(np.roots([1.0, want[0] * w1, want[1] * w1 ** 2])),
                                   atol=1e-12)
        assert max(np.real(got["poles"])) <= 0.0
        assert ("mirrored" in got["label"]) == (bad[0] < 0)
        assert ("written at zero" in got["label"]) == (bad[1] < 0)
        if bad[1] >= 0:       # the mirror keeps the amplitude
            written = np.abs(np.prod([s - q for q in got["poles"]], axis=0))
            np.testing.assert_allclose(written, np.abs(s ** 2 + bad[0] * w1 * s + b * w1 ** 2),
                                       rtol=1e-9)
        assert max(np.real(good["poles"])) < 0.0 and "mirrored" not in good["label"]


def test_negative_damping_on_two_pole_metadata_is_written_as_a_stable_pendulum():
    """On two-pole metadata, coordinates with negative damping (``a < 0``)
    are written as the mirrored pendulum: the same period, the damping's
    magnitude."""
    fam = TwoPoleFamily(period_s=120.0, damping=0.707, gain=1500.0, norm_freq=1.0,
                        gain_units="counts/(m/s)")
    e = SutCorner([0], [fam], ["c"], FMIN)
    a, b = _ab(40.0, 0.3)
    got = e.sut_response(np.array([-a, b]), 0)
    assert got["pendulum"] == pytest.approx((40.0, 0.3)) and "mirrored" in got["label"]

