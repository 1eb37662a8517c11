"""Corrected StationXML: fitted values in, errors from the 68 % interval,
everything else untouched; ObsPy reads them back."""
from __future__ import annotations

import numpy as np
import obspy
import pytest

import bayescal
from bayescal.core.response.family import TwoPoleFamily, evaluate_velocity_response
from bayescal.io.stationxml import corrected_inventory, write_corrected
from tests.conftest import SIM_BAND


@pytest.fixture(scope="module")
def orientation_post(sim_pair):
    return bayescal.calibrate(sut=sim_pair.sut, sut_xml=sim_pair.sut_inventory, ref=sim_pair.ref,
                              ref_xml=sim_pair.ref_inventory, band=SIM_BAND, progress=False)


def _channel(inv, code):
    return inv.select(channel=code)[0][0][0]


def _without_comments(xml):
    """The lines of ``xml`` without its <Comment> blocks (the provenance)."""
    out, inside = [], False
    for line in xml.splitlines():
        inside = inside or "<Comment" in line
        if not inside:
            out.append(line)
        inside = inside and "</Comment>" not in line
    return out


def test_real_stationxml_round_trip(orientation_post, tmp_path):
    """ObsPy's shipped real GR.FUR metadata (STS-2, full response) as the
    SUT's StationXML: only the fitted azimuths/dips change, with errors."""
    real = obspy.read_inventory().select(station="FUR", channel="BH?")
    original = tmp_path / "fur.xml"
    real.write(str(original), format="STATIONXML")
    rename = {"XX.SIM.10.BH1": "GR.FUR..BHN", "XX.SIM.10.BH2": "GR.FUR..BHE",
              "XX.SIM.10.BHZ": "GR.FUR..BHZ"}
    post = orientation_post.state.replace(
        channel_ids=[rename[c] for c in orientation_post.channel_ids],
        meta=orientation_post.meta.replace(nominal={})).to_result()   # as bayescal fit writes it
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
    # the near-vertical channel: dip (with errors) updated, azimuth the one
    # its axis leans toward (issue 14 item 7)
    z = _channel(back, "BHZ")
    assert z.dip == pytest.approx(summary["GR.FUR..BHZ"]["dip_deg"]["median"])
    assert summary["GR.FUR..BHZ"]["azimuth_deg"]["median"] is None
    assert z.azimuth == pytest.approx(summary["GR.FUR..BHZ"]["tilt_toward_azimuth_deg"] % 360,
                                      abs=0.5)
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
                                      _without_comments(out.read_text())) if x != y]
    assert all(("Azimuth" in x or "Dip" in x or "Created" in x or "Module" in x)
               for x, _ in changed), changed


def test_fitted_response_written_and_sensitivity_recalculated(tmp_path):
    """Joint fit of one simulated channel: the corrected StationXML holds the
    posterior median period, damping and gain, and a consistent sensitivity;
    the truth lies inside the written 95 % intervals. The result written as
    ``bayescal fit`` writes it: every interval of its result.json (period,
    damping, damping/period, gain, relative gain, tilt) is the one its label
    names, of the samples in its samples.npz (tests/intervals.py)."""
    from bayescal.io.result import save_posterior
    from bayescal.simulate.pair import simulate_pair
    from tests.intervals import assert_fit_folder

    truth = (27.0, 0.68, 780.0)
    sim = simulate_pair(duration=3600, fs=10, seed=5, coherence=0.99,
                        sut_response=((30.0, 0.707, 750.0),) * 2 + (truth,))
    post = bayescal.calibrate(sut=sim.sut.select(channel="BHZ"), sut_xml=sim.sut_inventory, ref=sim.ref,
                              ref_xml=sim.ref_inventory, band=SIM_BAND, fit_response="all",
                              progress=False)
    save_posterior(post, tmp_path / "result")
    # BHZ: tilt, dip, lean north and east; period, damping, damping/period, gain,
    # relative gain
    assert assert_fit_folder(tmp_path / "result") == 9
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


def test_tilted_vertical_gets_the_azimuth_it_leans_toward_and_provenance(tmp_path):
    """Issue 14 items 7 and 8: a vertical leaning 0.5 degree toward azimuth
    40 is written with dip and that azimuth; every changed channel carries a
    comment naming the reference, band, version and the 68 % convention."""
    from bayescal.simulate.pair import simulate_pair
    from bayescal.version import __version__
    from tests.conftest import SIM_KW

    pair = simulate_pair(**{**SIM_KW, "sut_azimuth": (3.0, 93.0, 40.0)})
    post = bayescal.calibrate(sut=pair.sut, sut_xml=pair.sut_inventory, ref=pair.ref, ref_xml=pair.ref_inventory,
                              band=SIM_BAND, progress=False)
    write_corrected(pair.sut_inventory, post, tmp_path / "c.xml")
    inv = obspy.read_inventory(str(tmp_path / "c.xml"))
    z = _channel(inv, "BHZ")
    assert abs(z.azimuth - 40.0) < 3 * max(z.azimuth.upper_uncertainty, 0.5)
    assert z.azimuth.lower_uncertainty > 0
    for code in ("BH1", "BH2", "BHZ"):
        text = " ".join(c.value for c in _channel(inv, code).comments)
        for word in ("XX.SIM.00.BHN", "0.03-1 Hz", __version__, "68 %"):
            assert word in text, (code, word, text)


def test_gain_interval_kept_and_flat_metadata_marked(sim_pair, tmp_path):
    """Issue 14 items 9 and 10: the fitted gain's 68 % interval is written
    (stage 1 Description and channel comment), and 'flat' metadata says what
    bayescal invented."""
    from bayescal.io.read import flat_inventory

    post = bayescal.calibrate(sut=sim_pair.sut, sut_xml=sim_pair.sut_inventory, ref=sim_pair.ref,
                              ref_xml=sim_pair.ref_inventory, band=SIM_BAND, fit_response="gain",
                              progress=False)
    write_corrected(sim_pair.sut_inventory, post, tmp_path / "g.xml")
    ch = _channel(obspy.read_inventory(str(tmp_path / "g.xml")), "BH1")
    lo, hi = post.summary()["channels"]["XX.SIM.10.BH1"]["response"]["gain"]["ci68"]
    desc = ch.response.response_stages[0].description
    assert f"{lo:.6g}" in desc and f"{hi:.6g}" in desc
    assert any(f"{lo:.6g}" in c.value for c in ch.comments)
    flat = flat_inventory(sim_pair.sut)
    flat.write(str(tmp_path / "flat.xml"), format="STATIONXML")
    for c in obspy.read_inventory(str(tmp_path / "flat.xml")).select(channel="BH?")[0][0]:
        text = " ".join(x.value for x in c.comments)
        assert "placeholder" in text and "flat 1 counts per m/s" in text
