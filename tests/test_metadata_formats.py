"""Metadata formats users have (issue 14 item 6): SEED RESP files and GSE2
``CAL1 ... PAZ`` poles and zeros are accepted wherever StationXML is, recognised
by their content (not their name).

* a GSE2 file's response is the analytic poles-and-zeros response (checked
  against the formula), and as the huddle reference it gives the same fit as
  the StationXML the example writes from it;
* a RESP file shipped with ObsPy's test data is read through
  ``read_inventory(format="RESP")`` whatever its file name, its BHZ gets its
  orientation from the channel code, and as the huddle reference (an STS-2 of
  the same nominal response) it gives the gain the GSE2 file gives.
"""
from __future__ import annotations

import json
import shutil
from pathlib import Path

import numpy as np
import pytest

#: A GSE2 PAZ file in the layout ObsPy's read_paz documents.
GSE2 = """CAL1 RJOB   LE-3D    Z  M24    PAZ 010824 0001
2
-4.39823 4.48709
-4.39823 -4.48709
2
0.0 0.0
0.0 0.0
400.0
"""


def _resp_file():
    import obspy
    path = (Path(obspy.__file__).parent / "io" / "xseed" / "tests" / "data"
            / "RESP.XX.NS085..BHZ.STS2_gen3.120.1500")
    if not path.is_file():
        pytest.skip("ObsPy's test data (RESP files) are not installed")
    return path


def _stream(net="XX", sta="RJOB", cha="EHZ", n=100):
    import obspy
    return obspy.Stream([obspy.Trace(np.arange(n, dtype=float),
                                     header=dict(network=net, station=sta, channel=cha,
                                                 sampling_rate=20.0))])


def test_gse2_paz_response_is_the_formula(tmp_path):
    from bayescal.core.response.family import evaluate_velocity_response
    from bayescal.io import metadata_format, read_metadata

    path = tmp_path / "le3d.cal"
    path.write_text(GSE2)
    assert metadata_format(path) == "GSE2"
    inv = read_metadata(path, stream=_stream())
    ch = inv.select(channel="EHZ")[0][0][0]
    assert (ch.azimuth, ch.dip) == (0.0, -90.0)
    assert "placeholder" in ch.comments[0].subject and "GSE2" in ch.comments[0].value
    f = np.array([0.1, 0.7, 1.0, 5.0])
    s = 2j * np.pi * f
    p = complex(-4.39823, 4.48709)
    want = 400.0 * s ** 2 / ((s - p) * (s - p.conjugate()))   # A0 = 1, as rel_calib_stack
    got = evaluate_velocity_response(ch.response, f)
    np.testing.assert_allclose(np.abs(got), np.abs(want), rtol=1e-6)
    np.testing.assert_allclose(np.angle(got / want), 0.0, atol=1e-6)


def test_gse2_without_recordings_and_bad_resp_are_one_line_errors(tmp_path):
    from bayescal.errors import InputError
    from bayescal.io import read_metadata

    cal = tmp_path / "sensor.cal"
    cal.write_text(GSE2)
    with pytest.raises(InputError, match="sensor.cal: a GSE2 poles-and-zeros file names no"):
        read_metadata(cal)
    bad = tmp_path / "broken.resp"
    bad.write_text("B050F03     Station:     X\nB053F03     Transfer function type: ???\n")
    with pytest.raises(InputError, match="broken.resp: not a RESP file"):
        read_metadata(bad)


def test_resp_recognised_by_content(tmp_path):
    from bayescal.core.response.family import evaluate_velocity_response
    from bayescal.io import metadata_format, read_metadata
    from bayescal.io.read import channel_meta

    path = tmp_path / "sts2.xml"   # the name says StationXML; the content decides
    shutil.copy(_resp_file(), path)
    assert metadata_format(path) == "RESP"
    inv = read_metadata(path)
    tr = _stream(net="XX", sta="NS085", cha="BHZ")[0]
    tr.stats.starttime = "2011-02-15"
    ch, az, dip = channel_meta(inv, tr, str(path))
    assert (az, dip) == (0.0, -90.0)   # RESP has no orientation: the code's
    # the file's stage-1 gain 1500 at 1 Hz (B058F04), normalised there
    assert abs(abs(evaluate_velocity_response(ch.response, np.array([1.0]))[0]) - 1500) < 1.5


def _huddle_fit(huddle_data, tmp_path, ref, ref_xml, name):
    from bayescal.cli import main
    from bayescal.io import two_pole_inventory, read_waveforms

    sut_xml = tmp_path / "unknown.xml"
    if not sut_xml.exists():   # the example's nominal SUT metadata
        two_pole_inventory(read_waveforms(huddle_data / "ref_unknown"), 120.0, 0.707,
                           1500.0).write(str(sut_xml), format="STATIONXML")
    out = tmp_path / name
    assert main(["fit", "--ref", str(ref), "--ref-xml", str(ref_xml),
                 "--sut", str(huddle_data / "ref_unknown"), "--sut-xml", str(sut_xml),
                 "--out", str(out), "--fit-response", "gain", "--band", "0.1", "2",
                 "--quiet", "--no-report"]) == 0
    res = json.loads((out / "result.json").read_text())
    return res["channels"]["CA.0438..EHZ"]["response"]["gain"]


def test_gse2_and_resp_as_huddle_reference(huddle_data, tmp_path):
    import obspy

    from bayescal.io import paz_inventory, read_gse2_paz, read_waveforms

    cal = huddle_data / "STS2_simp.cal"
    g_cal = _huddle_fit(huddle_data, tmp_path, huddle_data / "ref_STS2", cal, "cal")
    # the same poles and zeros written as StationXML (examples/real_huddle.py)
    poles, zeros, gain = read_gse2_paz(cal)
    xml = tmp_path / "ref.xml"
    paz_inventory(read_waveforms(huddle_data / "ref_STS2"), zeros=zeros, poles=poles, gain=gain,
                  normalize=False).write(str(xml), format="STATIONXML")
    g_xml = _huddle_fit(huddle_data, tmp_path, huddle_data / "ref_STS2", xml, "xml")
    assert g_cal["median"] == pytest.approx(g_xml["median"], rel=1e-9)
    # ObsPy's rel_calib_stack gives 1130-1154 over 0.3-3 Hz (README)
    assert 1120 < g_cal["median"] < 1175
    # the RESP of an STS-2 (T0 120 s, h 0.707, 1500 counts/(m/s)) with its
    # channel's id on the reference trace: same gain within its extra stages
    st = obspy.read(str(huddle_data / "ref_STS2"))
    st[0].stats.network, st[0].stats.station, st[0].stats.channel = "XX", "NS085", "BHZ"
    ref = tmp_path / "ref_as_ns085.mseed"
    st.write(str(ref), format="MSEED")
    g_resp = _huddle_fit(huddle_data, tmp_path, ref, _resp_file(), "resp")
    assert g_resp["median"] == pytest.approx(g_cal["median"], rel=0.01)
    lo, hi = g_cal["ci95"]
    assert lo - 0.01 * g_cal["median"] < g_resp["median"] < hi + 0.01 * g_cal["median"]
