"""The response as the data see it (result.json's ``response_curve``): on a
simulated pair whose reference has a pole its metadata lack, and on the
README's clock example (the SUT's clock 0.3 s late), each SUT channel's
curve under the headline model holds the simulator's true response ratio
H_sut / H_ref (closed form, :func:`bayescal.core.response.paz_velocity_response`)
within its band, where the metadata's ratio does not; the clock is left out
of the curve and stated as a time correction; the report rebuilt from the
files draws the page."""
from __future__ import annotations

import json
import pathlib
import subprocess
import sys
import warnings

import numpy as np
import pytest

import bayescal
from bayescal.core.response import paz_velocity_response
from bayescal.io.result import write_results
from bayescal.simulate.pair import DIGITIZER_GAIN, simulate_pair
from tests.tolerance import Z_001

SUT, REF = (30.0, 0.707, 750.0), (120.0, 0.707, 1500.0)
POLE_HZ = 0.8
#: The simulated reference's metadata of each fit (by the Result's id).
REF_METADATA = {}


def _fit(band, **sim):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        s = simulate_pair(**sim)
        post = bayescal.calibrate(sut=s.sut, sut_xml=s.sut_inventory, ref=s.ref,
                                  ref_xml=s.ref_inventory, band=band, progress=False,
                                  min_ess=200, n_tau=20)
    REF_METADATA[id(post)] = s.ref_inventory     # for the StationXML's check
    return post


@pytest.fixture(scope="module")
def ref_pole():
    """A pair whose reference has a real pole at 0.8 Hz its metadata lack."""
    return _fit((0.05, 3.0), duration=3600, fs=10, seed=1, sut_azimuth=(5.0, 95.0, 0.0),
                nominal_azimuth=(3.0, 93.0, 0.0), extra_pole=("ref", POLE_HZ))


@pytest.fixture(scope="module")
def late():
    """The README's clock example: the SUT's samples 0.3 s late."""
    return _fit((0.03, 1.0), duration=1800, fs=10, seed=2, timing_offset_s=0.3)


def true_ratio(f, ref_poles=()):
    """The simulator's H_sut / H_ref (counts over counts), closed form."""
    return (paz_velocity_response(f, *SUT, digitizer_gain=DIGITIZER_GAIN)
            / paz_velocity_response(f, *REF, extra_poles=ref_poles, digitizer_gain=DIGITIZER_GAIN))


def _within(entry, truth):
    """|median - truth| within Z_001 standard deviations of the 95 % band
    (sd = half its width / 1.96; level 0.001 per point), at every frequency."""
    med = np.asarray(entry["median"])
    lo, hi = (np.asarray(x) for x in entry["ci95"])
    sd = (hi - lo) / (2 * 1.96)
    return np.abs(med - truth) <= Z_001 * sd + 1e-12 * np.abs(truth)


def test_curve_holds_the_true_ratio_of_a_reference_pole_the_metadata_lack(ref_pole):
    curve = ref_pole.summary()["response_curve"]
    assert ref_pole.meta.headline["model"] == "improved"
    assert curve["effects"] == ["extra_pole"] and curve["left_out"] == []
    assert "time_correction" not in curve
    f = np.asarray(curve["freq_hz"])
    lo, hi = ref_pole.meta.band_hz
    assert lo <= f[0] < 1.1 * lo and 0.95 * hi < f[-1] <= hi       # the band's first and last bins
    assert np.allclose(np.diff(np.log10(f)), np.log10(f[-1] / f[0]) / (f.size - 1), rtol=0.1)
    truth = true_ratio(f, [-2 * np.pi * POLE_HZ])
    pairs = {"XX.SIM.10.BH1": "XX.SIM.00.BHN", "XX.SIM.10.BH2": "XX.SIM.00.BHE",
             "XX.SIM.10.BHZ": "XX.SIM.00.BHZ"}
    for cid, entry in curve["channels"].items():
        assert entry["reference"] == pairs[cid]
        assert _within(entry["amplitude"], np.abs(truth)).all(), cid
        assert _within(entry["phase_rad"], np.angle(truth)).all(), cid
        # the metadata alone miss the pole (normalised at 1 Hz): |1 + i f / 0.8| over its 1 Hz value
        meta = np.asarray(entry["metadata"]["amplitude"])
        missed = np.hypot(1, f / POLE_HZ) / np.hypot(1, 1 / POLE_HZ)
        assert np.allclose(np.abs(truth) / meta, missed, rtol=1e-6)
        assert not _within(entry["amplitude"], meta).all()


def test_clock_is_a_time_correction_not_response(late):
    curve = late.summary()["response_curve"]
    assert late.meta.headline["model"] == "improved"
    assert curve["effects"] == [] and curve["left_out"] == ["timing_offset"]
    clock = curve["time_correction"]
    lo, hi = clock["seconds"]["ci95"]
    assert lo <= 0.3 <= hi
    assert f"correct the SUT data's start time by {-clock['seconds']['median']:+.4g} s" in \
        clock["text"] and "s late" in clock["text"]
    f = np.asarray(curve["freq_hz"])
    truth = true_ratio(f)
    for cid, entry in curve["channels"].items():
        assert _within(entry["amplitude"], np.abs(truth)).all(), cid
        # no delay in the phase: 0.3 s would turn it by 2 pi f 0.3 (1.9 rad at 1 Hz)
        assert np.allclose(entry["phase_rad"]["median"], np.angle(truth), atol=1e-6), cid


def test_console_gives_the_time_correction(late):
    import contextlib
    import io

    from bayescal.cli.fit import print_summary

    out = io.StringIO()
    with contextlib.redirect_stdout(out):
        print_summary(late.summary())
    clock = late.response_curve["time_correction"]
    assert f"time correction: {clock['text']}" in out.getvalue()
    assert out.getvalue().count("time correction: the SUT's clock is 0.") == 1


def test_report_rebuilt_from_files_draws_the_curve(late, tmp_path):
    import pypdf

    write_results(late, str(tmp_path))
    saved = json.loads((tmp_path / "result.json").read_text())["response_curve"]
    live = late.summary()["response_curve"]
    assert saved["channels"].keys() == live["channels"].keys()
    for cid, entry in saved["channels"].items():
        for key in ("amplitude", "phase_rad"):
            np.testing.assert_array_equal(entry[key]["ci95"], live["channels"][cid][key]["ci95"])
    assert bayescal.load_posterior(str(tmp_path)).response_curve == saved
    root = pathlib.Path(__file__).resolve().parents[1]
    subprocess.run([sys.executable, "-m", "bayescal.cli", "report", str(tmp_path), "--png"], check=True,
                   capture_output=True, text=True, cwd=str(root))
    assert (tmp_path / "report_response_curve.png").exists()
    from bayescal.report.fit import PAGES
    pdf = pypdf.PdfReader(str(tmp_path / "report.pdf"))
    drawn = [n for name in PAGES for n in (name, f"{name}_2", f"{name}_3")   # page 1 may run on
             if (tmp_path / f"report_{n}.png").exists()]
    page = pdf.pages[drawn.index("response_curve")].extract_text()
    text = " ".join(page.split())
    assert "response as the data see it" in text
    assert "relative to the reference's metadata" in text
    assert "correct the SUT data's start time by" in text


def test_stationxml_writes_the_response_as_the_data_see_it(ref_pole, tmp_path):
    """The corrected StationXML read back with ObsPy: the reference's
    missing pole is the SUT's zero in a stage of its own (unit gain at 1 Hz,
    the sensor's and the digitizer's stages as they were), and the SUT's
    response it gives, over the reference's metadata response, is the
    closed form of what was written (the metadata ratio times the fitted
    gain over the metadata gain times the zero's factor) and the curve's
    median (to 0.5 % and 0.005 rad: the curve's median against the curve
    at the parameters' medians) at every grid frequency."""
    from obspy import UTCDateTime, read_inventory

    from bayescal.core.response import evaluate_velocity_response

    write_results(ref_pole, str(tmp_path))
    inv = read_inventory(str(tmp_path / "sut_corrected.xml"))
    curve = ref_pole.response_curve
    f = np.asarray(curve["freq_hz"])
    corner = ref_pole.summary()["criticism"]["effects"][0]["size"]["corner_hz"]["median"]
    time = UTCDateTime(ref_pole.meta.starttime)
    s, sn = 2j * np.pi * f, 2j * np.pi * 1.0
    for cid, entry in curve["channels"].items():
        net, sta, loc, cha = cid.split(".")
        ch = inv.select(network=net, station=sta, location=loc, channel=cha)[0][0][0]
        stages = ch.response.response_stages
        assert [st.stage_sequence_number for st in stages] == [1, 2, 3]
        (zero,) = stages[1].zeros
        assert stages[1].poles == [] and stages[1].stage_gain == 1.0
        assert complex(zero) == pytest.approx(-2 * np.pi * corner, rel=0.02)
        assert any(entry["reference"] in c.value and "relative to the reference's metadata"
                   in c.value for c in ch.comments)
        h = ch.response.get_evalresp_response_for_frequencies(f, output="VEL")
        h_ref = evaluate_velocity_response(
            REF_METADATA[id(ref_pole)].get_response(entry["reference"], time), f)
        ratio = h / h_ref
        gain = ref_pole.channels[cid]["response"]["gain"]["median"]
        meta = entry["metadata"]
        written = (np.asarray(meta["amplitude"]) * np.exp(1j * np.asarray(meta["phase_rad"]))
                   * gain / SUT[2] * (s - complex(zero)) / abs(sn - complex(zero)))
        np.testing.assert_allclose(ratio, written, rtol=1e-6)
        np.testing.assert_allclose(np.abs(ratio), entry["amplitude"]["median"], rtol=5e-3)
        np.testing.assert_allclose(np.angle(ratio), entry["phase_rad"]["median"], atol=5e-3)


@pytest.mark.parametrize("kind", ["zero", "pole", "pendulum", "gain"])
def test_each_change_written_is_its_closed_form(kind):
    """Each change of the SUT's response the corrected StationXML writes,
    evaluated by ObsPy, is the closed form of that change on the metadata
    response: a zero or a pole at 5 Hz (normalised at 1 Hz) in a stage of
    its own, a pendulum of 60 s and damping 0.5, a sensitivity 3 % high."""
    import copy

    from bayescal.core.response import response_family
    from bayescal.io.relative_response import change, write_changes
    from bayescal.io.stationxml import recalculate_sensitivity, write_pendulum
    from bayescal.simulate.pair import NORM_FREQ, velocity_response

    resp = velocity_response(*SUT)
    f = np.geomspace(0.01, 8.0, 25)
    w = -2 * np.pi * 5.0
    s, sn = 2j * np.pi * f, 2j * np.pi * NORM_FREQ
    before = resp.get_evalresp_response_for_frequencies(f, output="VEL")
    c, want = {
        "zero": (change(zeros=[w], norm_freq=NORM_FREQ), before * (s - w) / abs(sn - w)),
        "pole": (change(poles=[w], norm_freq=NORM_FREQ), before * abs(sn - w) / (s - w)),
        "pendulum": (change(pendulum=(60.0, 0.5)),
                     paz_velocity_response(f, 60.0, 0.5, SUT[2], digitizer_gain=DIGITIZER_GAIN)),
        "gain": (change(gain_factor=1.03), before * 1.03)}[kind]

    class Channel:
        response = copy.deepcopy(resp)
        code = "BHZ"

    fam = response_family(resp)
    assert write_changes(Channel, [c], lambda st, t, h: write_pendulum(st, fam, t, h))
    recalculate_sensitivity(Channel, fam.norm_freq)
    got = Channel.response.get_evalresp_response_for_frequencies(f, output="VEL")
    np.testing.assert_allclose(got, want, rtol=1e-9)
    n_stages = 3 if kind in ("zero", "pole") else 2
    assert len(Channel.response.response_stages) == n_stages
    sens = Channel.response.instrument_sensitivity
    assert sens.value == pytest.approx(abs(Channel.response.get_evalresp_response_for_frequencies(
        [sens.frequency], output="VEL")[0]), rel=1e-9)


def test_the_one_response_evaluation_is_the_likelihoods_own_factor(ref_pole, late):
    """The fitted response (bayescal.criticism.fitted_response.model_response,
    which result.json's curve and the criticism's relative response both
    use) at the model's nodes is the reciprocal of the likelihood's own
    deconvolution factor (Model.unpack), a clock offset's delay taken out
    of it: on the reference-pole pair's and the late clock's improved
    models (an extra pole; a timing offset)."""
    from bayescal.core.model import is_clock
    from bayescal.criticism.fitted_response import model_response, relative_response
    from bayescal.pair.response_curve import response_factor

    for post in (ref_pole, late):
        st = post.improved.state
        m, th = st.model, st.full_samples[::50]
        assert m.effects, "no improved model"
        _, ratio = m.unpack(th)
        for e, sl in zip(m.effects, m.effect_slices):
            if is_clock(e) and not e.blocked:
                ratio[:, e.rows] /= e.factor(m.nodes, th[:, sl])
        np.testing.assert_allclose(model_response(m, th, m.nodes), 1.0 / ratio, rtol=1e-10)
        np.testing.assert_allclose(response_factor(m, th), 1.0 / ratio, rtol=1e-10)
        np.testing.assert_allclose(relative_response(st, m.nodes, timing=False)[::50],
                                   1.0 / ratio, rtol=1e-10)


def test_stationxml_from_a_result_read_back_says_what_it_could_not_write(ref_pole, tmp_path):
    """A result read back from its files holds no model: the corrected
    StationXML written from it keeps the SUT's metadata response and its
    comment says the improved model's response effects are not written
    (it does not claim a response it did not write)."""
    from obspy import read_inventory

    from bayescal.io.result import write_corrected_result

    write_results(ref_pole, str(tmp_path / "fit"))
    loaded = bayescal.load_posterior(str(tmp_path / "fit"))
    write_corrected_result(ref_pole.state.sut_inventory, loaded, str(tmp_path / "again.xml"))
    again = read_inventory(str(tmp_path / "again.xml"))
    for cid in ref_pole.response_curve["channels"]:
        net, sta, loc, cha = cid.split(".")
        ch = again.select(network=net, station=sta, location=loc, channel=cha)[0][0][0]
        said = [c.value for c in ch.comments if "relative to the reference's metadata" in c.value]
        assert said and "not written: the improved model's response effects" in said[0]
        assert "it carries" not in said[0]
