"""Validation on real recordings (../shared/data; skipped when absent).

* ASL COWI azimuth set: the COWI horizontals are rotated 3.2 degrees
  clockwise from the AZI8 reference (ASL Sensor Test Suite's own test,
  tolerance 0.5 degree).
* ObsPy huddle pair: the unknown sensor's fitted response over 0.3-3 Hz
  reproduces ObsPy's rel_calib_stack amplitude (about 1130, README).
"""
from __future__ import annotations

import json
import sys
from pathlib import Path

import numpy as np
import pytest

from tests.test_cli_fit import expected_segments

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "examples"))

PUBLISHED_COWI_DEG, COWI_TOL = 3.2, 0.5
PUBLISHED_HUDDLE_AMP = 1130.0


@pytest.mark.parametrize("gains", ["held", "free", "default"])
def test_cowi_horizontal_azimuths_match_asl(cowi_data, tmp_path, gains):
    """ASL's test: each horizontal's rotation from the reference within ASL's
    tolerance (0.5 degree) of 3.2, and the 95 % interval narrower than that
    tolerance band, whether the gains are held, free or the reference's noise
    estimated (the default). ASL publishes a tolerance, not an interval, so
    whether our 95 % interval holds the point 3.2 is not a test of either.
    Which of the two sensors is the noisier has no published answer, so
    the sensor-order verdict is not checked here. The window is complete,
    so the segments used are those the stated segment rule keeps."""
    from real_cowi import command, rotation

    from bayescal.cli import main

    out = tmp_path / "cowi"
    args = command(cowi_data, str(out)) + {"held": ["--fit-response", "none", "--ref-noise",
                                                    "quiet"],
                                           "free": ["--ref-noise", "quiet"], "default": []}[gains]
    assert main(args) == 0
    res = json.loads((out / "result.json").read_text())
    rot = rotation(res["channels"])
    assert set(rot) == {"US.COWI..LHN", "US.COWI..LHE"}
    assert list(res["not_estimable"]) == ["US.COWI..LHZ"]
    for cid, r in rot.items():
        # the model misses this pair (misfit up to 18 per band); the per-band
        # noise scale widens the interval
        assert abs(r["median"] - PUBLISHED_COWI_DEG) < COWI_TOL, (cid, r)
        lo, hi = r["ci95"]
        assert hi - lo < 2 * COWI_TOL, (cid, r)
    assert res["convergence"]["converged"]
    rn = res["meta"]["reference_noise"]
    # the headline's treatment: the improved model's when the verdict puts it
    # there, whose criticism models the reference's noise when it finds it
    chosen = res["meta"]["headline"]["model"] == "improved" and rn.get("chosen_by") == "diagnose"
    assert rn["mode"] == ("estimate" if gains == "default" or chosen else "quiet")
    # the reference has gaps elsewhere, but this window is complete
    meta = res["meta"]
    n = int(round(meta["duration_s"] * meta["sampling_rate"]))
    kept, possible = expected_segments(n, meta["sampling_rate"], meta["band_hz"][0],
                                       meta["segment_s"])
    used = meta["data_used"]
    # every gap-free segment is used but those holding a transient in one sensor
    transients = used.get("transients", {}).get("dropped", 0)
    assert (used["segments"] + transients, used["segments_possible"]) == (kept, possible)


def test_huddle_response_reproduces_rel_calib(huddle_data, tmp_path):
    from real_huddle import BAND, COMPARE_BAND, fitted_amplitude, obspy_rel_calib, write_inputs

    from bayescal.cli import main

    ref_xml, sut_xml = write_inputs(huddle_data, str(tmp_path / "inputs"))
    out = tmp_path / "fit"
    rc = main(["fit", "--ref", str(huddle_data / "ref_STS2"), "--ref-xml", ref_xml,
               "--sut", str(huddle_data / "ref_unknown"), "--sut-xml", sut_xml, "--out", str(out),
               "--fit-response", "--band", str(BAND[0]), str(BAND[1]), "--quiet", "--no-report"])
    assert rc == 0
    res = json.loads((out / "result.json").read_text())
    r = res["channels"]["CA.0438..EHZ"]["response"]
    assert set(r) == {"period_s", "damping", "damping_over_period", "gain", "relative_gain"}
    nominal = res["channels"]["CA.0438..EHZ"]["nominal"]["gain"]
    assert r["relative_gain"]["median"] == pytest.approx(r["gain"]["median"] / nominal, rel=1e-3)
    med, lo, hi = fitted_amplitude(str(out), sut_xml)
    unsmoothed = obspy_rel_calib(huddle_data, smooth=0)
    # the published (README) figure, from rel_calib_stack with smooth=10;
    # its Konno-Ohmachi smoothing lowers the amplitude by 2 % (1153.6 -> 1130)
    assert abs(med / PUBLISHED_HUDDLE_AMP - 1) < 0.035
    # the same estimator without smoothing: agreement within 1 %
    assert abs(med / unsmoothed - 1) < 0.01
    # 95 % interval 1.15 % wide (0.8 % under the Gaussian likelihood): the
    # misfit above 1.4 Hz (poles missing from STS2_simp.cal) widens it. It
    # may not be wider than ObsPy's own per-frequency amplitudes spread over
    # the band (3.92 times their sd about their median, 2.0 %): wider would
    # say the whole band knows the gain less well than one frequency does
    from obspy import read
    from obspy.signal.calibration import rel_calib_stack
    f, amp, _ = rel_calib_stack(read(str(huddle_data / "ref_STS2")), read(str(huddle_data / "ref_unknown")),
                                str(huddle_data / "STS2_simp.cal"), 20, smooth=0, save_data=False)
    a = amp[(f >= COMPARE_BAND[0]) & (f <= COMPARE_BAND[1])]
    assert hi - lo < 3.92 * np.std(a), (lo, hi, np.std(a))
    # the fitted gain is the amplitude in this band (flat there)
    assert r["gain"]["median"] == pytest.approx(med, rel=0.01)
    assert np.isfinite(r["period_s"]["median"]) and 0.02 <= r["damping"]["median"] <= 2.0


def test_cowi_band_chosen_from_coherence(cowi_data):
    """Without --band: the chosen band covers the secondary microseism,
    leaves out the vertical (no vertical reference), and the azimuths still
    agree with ASL."""
    from bayescal.pair.workflow import calibrate_files

    post = calibrate_files(sut=cowi_data / "C100823215422_COWI.LHx", sut_xml="flat",
                           ref=[cowi_data / "DT000110.LH1", cowi_data / "DT000110.LH2"], ref_xml="flat",
                           start="2010-08-24T02:00:00", end="2010-08-24T13:00:00",
                           progress=False)
    lo, hi = post.meta.band_hz
    assert lo <= 1 / 8 and hi >= 1 / 3
    assert "LHZ" not in post.meta.band_choice
    az = post.summary()["channels"]
    assert abs(az["US.COWI..LHN"]["azimuth_deg"]["median"] - PUBLISHED_COWI_DEG) < COWI_TOL
    assert abs(az["US.COWI..LHE"]["azimuth_deg"]["median"] - 90 - PUBLISHED_COWI_DEG) < COWI_TOL
