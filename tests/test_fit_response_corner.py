"""The wide corner offered where the fit samples period and damping under
the sensor's stated prior (``--fit-response all``), chosen by the
prior-data conflict test (bayescal.criticism.prior_choice): a 360-s sensor
whose StationXML names a 120-s one."""
from __future__ import annotations

import warnings

import pytest

TRUTH = (360.0, 0.707)


@pytest.fixture(scope="module")
def wrong_instrument():
    import bayescal
    from bayescal.simulate import simulate_pair

    sim = simulate_pair(duration=1800.0, fs=4.0, seed=2, sut_response=((*TRUTH, 750.0),) * 3,
                        nominal_response=(120.0, 0.707, 750.0),
                        ref_response=(120.0, 0.707, 1500.0), noise_in_counts=True)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        res = bayescal.calibrate(ref=sim.ref, ref_xml=sim.ref_inventory, sut=sim.sut,
                                 sut_xml=sim.sut_inventory, fit_response="all", seed=0,
                                 progress=False)
    return sim, res


def test_fitted_pendulum_under_a_wrong_prior_gives_way_to_the_wide_corner(wrong_instrument):
    """The 5 % prior around 120 s, 0.707 (damping/period 0.0059 1/s) holds
    the fitted pendulum far from the truth (0.707 / 360 = 0.00196 1/s): the
    data conflict with it, the corner is named, and each channel's 95 %
    interval of damping/period holds the truth and excludes the metadata's
    value."""
    sim, res = wrong_instrument
    c = res.summary()["criticism"]
    named = [e for e in c["effects"] if e["name"] == "sut_corner"]
    assert named, c["sentences"]
    for tr in sim.sut:
        lo, hi = named[0]["size"][f"damping_over_period:{tr.id}"]["ci95"]
        assert lo <= TRUTH[1] / TRUTH[0] <= hi, (tr.id, lo, hi)
        assert hi < 0.707 / 120.0
    # the channels table holds no period or damping at the metadata's values
    # as if fitted: the corner's entry carries them
    for ch in res.channels.values():
        assert "period_s" not in ch.get("response", {}) and "damping" not in ch.get("response", {})

