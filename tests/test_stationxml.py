"""Corrected StationXML: fitted values in, errors from the 68 % interval,
everything else untouched; ObsPy reads them back."""
from __future__ import annotations

import copy

import numpy as np
import obspy
import pytest

import bayescal
from bayescal.core.response import TwoPoleFamily, evaluate_velocity_response
from bayescal.io.stationxml import corrected_inventory, write_corrected
from tests.conftest import SIM_BAND


@pytest.fixture(scope="module")
def orientation_post(sim_pair):
    return bayescal.calibrate(sim_pair.sut, sim_pair.sut_inventory, sim_pair.ref,
                              sim_pair.ref_inventory, band=SIM_BAND, progress=False)


def _channel(inv, code):
    return inv.select(channel=code)[0][0][0]


def test_real_stationxml_round_trip(orientation_post, tmp_path):
    """ObsPy's shipped real GR.FUR metadata (STS-2, full response) as the
    SUT's StationXML: only the fitted azimuths/dips change, with errors."""
    real = obspy.read_inventory().select(station="FUR", channel="BH?")
    original = tmp_path / "fur.xml"
    real.write(str(original), format="STATIONXML")
    post = copy.copy(orientation_post)
    rename = {"XX.SIM.10.BH1": "GR.FUR..BHN", "XX.SIM.10.BH2": "GR.FUR..BHE",
              "XX.SIM.10.BHZ": "GR.FUR..BHZ"}
    post.channel_ids = [rename[c] for c in orientation_post.channel_ids]
    post.meta = dict(orientation_post.meta, nominal={})
    out = tmp_path / "sut_corrected.xml"
    write_corrected(obspy.read_inventory(str(original)), post, out)
    back = obspy.read_inventory(str(out))
    summary = post.summary()["channels"]
    for cid in ("GR.FUR..BHN", "GR.FUR..BHE"):
        ch = _channel(back, cid.split(".")[-1])
        az = summary[cid]["azimuth_deg"]
        assert ch.azimuth == pytest.approx(az["median"] % 360, abs=1e-9)
        assert ch.azimuth.lower_uncertainty == pytest.approx(az["median"] - az["ci68"][0])
        assert ch.azimuth.upper_uncertainty == pytest.approx(az["ci68"][1] - az["median"])
        assert ch.azimuth.lower_uncertainty > 0 and ch.azimuth.upper_uncertainty > 0
        dip = summary[cid]["dip_deg"]
        assert ch.dip == pytest.approx(dip["median"])
        assert ch.dip.upper_uncertainty == pytest.approx(dip["ci68"][1] - dip["median"])
    # the near-vertical channel: dip (with errors) updated, azimuth kept
    z = _channel(back, "BHZ")
    assert z.dip == pytest.approx(summary["GR.FUR..BHZ"]["dip_deg"]["median"])
    assert z.azimuth == _channel(real, "BHZ").azimuth
    # everything else untouched: responses, coordinates, other fields
    for code in ("BHZ", "BHN", "BHE"):
        a, b = _channel(real, code), _channel(back, code)
        assert str(a.response) == str(b.response)
        for attr in ("latitude", "longitude", "elevation", "depth", "sample_rate", "start_date",
                     "sensor", "location_code"):
            assert getattr(a, attr) == getattr(b, attr), (code, attr)
        f = np.geomspace(0.01, 10, 30)
        np.testing.assert_allclose(evaluate_velocity_response(b.response, f),
                                   evaluate_velocity_response(a.response, f))
    changed = [(x, y) for x, y in zip(original.read_text().splitlines(),
                                      out.read_text().splitlines()) if x != y]
    assert all(("Azimuth" in x or "Dip" in x or "Created" in x or "Module" in x)
               for x, _ in changed), changed


def test_fitted_response_written_and_sensitivity_recalculated(tmp_path):
    """Joint fit of one simulated channel: the corrected StationXML holds the
    posterior median period, damping and gain, and a consistent sensitivity;
    the truth lies inside the written 95 % intervals."""
    from bayescal.simulate.pair import simulate_pair

    truth = (27.0, 0.68, 780.0)
    sim = simulate_pair(duration=3600, fs=10, seed=5, coherence=0.99,
                        sut_response=((30.0, 0.707, 750.0),) * 2 + (truth,))
    post = bayescal.calibrate(sim.sut.select(channel="BHZ"), sim.sut_inventory, sim.ref,
                              sim.ref_inventory, band=SIM_BAND, fit_response="all",
                              progress=False)
    out = tmp_path / "c.xml"
    write_corrected(sim.sut_inventory, post, out)
    back = obspy.read_inventory(str(out))
    resp = _channel(back, "BHZ").response
    fam = TwoPoleFamily.from_response(resp)
    r = post.summary()["channels"]["XX.SIM.10.BHZ"]["response"]
    assert fam.period_s == pytest.approx(r["period_s"]["median"], rel=1e-6)
    assert fam.damping == pytest.approx(r["damping"]["median"], rel=1e-6)
    assert fam.gain == pytest.approx(r["gain"]["median"], rel=1e-9)
    for name, value in zip(("period_s", "damping", "gain"), truth):
        lo, hi = r[name]["ci95"]
        assert lo < value < hi, (name, lo, value, hi)
    poles = sorted(resp.response_stages[0].poles, key=abs)[:2]
    assert all(p.lower_uncertainty is not None and abs(p.upper_uncertainty) > 0 for p in poles)
    sens = resp.instrument_sensitivity
    assert abs(evaluate_velocity_response(resp, [sens.frequency])[0]) == \
        pytest.approx(sens.value, rel=1e-4)
    # the gain at the normalization frequency is the fitted G (A0 re-normalised)
    nominal = _channel(sim.sut_inventory, "BHZ").response
    fn = [fam.norm_freq]
    ratio = abs(evaluate_velocity_response(resp, fn)[0] / evaluate_velocity_response(nominal, fn)[0])
    assert ratio == pytest.approx(r["gain"]["median"] / 750.0, rel=1e-6)
    # unfitted channels untouched
    for code in ("BH1", "BH2"):
        assert str(_channel(back, code).response) == str(_channel(sim.sut_inventory, code).response)
        assert _channel(back, code).azimuth == _channel(sim.sut_inventory, code).azimuth


def test_corrected_inventory_does_not_modify_its_input(orientation_post, sim_pair):
    before = str(sim_pair.sut_inventory.select(channel="BH1")[0][0][0])
    corrected_inventory(sim_pair.sut_inventory, orientation_post)
    assert str(sim_pair.sut_inventory.select(channel="BH1")[0][0][0]) == before
