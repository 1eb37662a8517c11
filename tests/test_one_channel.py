"""One-channel references (issue 14, items 3 and 13): two SUT horizontals
against one reference horizontal (ASL's orthogonal rotation, stated in the
output), a vertical against a vertical with its gain held (--fit-response
none: a clear refusal, not a crash) and by default, gain free (no azimuth of
180 degrees invented)."""
from __future__ import annotations

import json

import numpy as np
import pytest

from tests.conftest import SIM_BAND
from tests.test_cli_fit import assert_user_error, base_args, run_fit
from tests.test_real_data import COWI_TOL, PUBLISHED_COWI_DEG
from tests.tolerance import Z_001, median_mc_error

COWI_WINDOW = ["--band", "0.125", "0.3333333", "--start", "2010-08-24T02:00:00",
               "--end", "2010-08-24T13:00:00"]


def test_two_horizontals_against_one_reference_channel(sim_files, sim_pair, tmp_path):
    out = tmp_path / "o"
    proc = run_fit(*base_args(sim_files), "--ref-id", "XX.SIM.00.BHN", "--band", *SIM_BAND,
                   out=out)
    assert proc.returncode == 0, proc.stderr
    res = json.loads((out / "result.json").read_text())
    assert "orthogonal" in res["meta"]["assumption"]
    truth = sim_pair.truth["channels"]["XX.SIM.10.BH1"]["azimuth_deg"]     # 3.0
    az1 = res["channels"]["XX.SIM.10.BH1"]["azimuth_deg"]
    az2 = res["channels"]["XX.SIM.10.BH2"]["azimuth_deg"]
    # the median within Z_001 = 3.29 posterior sds of the truth (its Monte
    # Carlo error added): a single check at the suite's level 0.001
    ess = res["convergence"]["ess_min"]
    assert abs(az1["median"] - truth) < Z_001 * np.hypot(az1["sd"], median_mc_error(az1, ess)), az1
    assert az2["median"] - az1["median"] == pytest.approx(90.0, abs=1e-9)
    assert list(res["not_estimable"]) == ["XX.SIM.10.BHZ"]


def test_cowi_against_azi8_lh1_alone_matches_asl(cowi_data, tmp_path):
    """ASL's own azimuth test inputs: COWI LHN+LHE against AZI8 LH1 only."""
    from bayescal.cli import main

    out = tmp_path / "cowi1"
    rc = main(["fit", "--ref", str(cowi_data / "DT000110.LH1"), "--ref-xml", "flat",
               "--sut", str(cowi_data / "C100823215422_COWI.LHx"), "--sut-xml", "flat",
               "--out", str(out), *COWI_WINDOW, "--quiet", "--no-report"])
    assert rc == 0
    res = json.loads((out / "result.json").read_text())
    lhn = res["channels"]["US.COWI..LHN"]["azimuth_deg"]
    assert abs(lhn["median"] - PUBLISHED_COWI_DEG) < COWI_TOL
    assert lhn["ci95"][1] - lhn["ci95"][0] < 2 * COWI_TOL
    assert res["channels"]["US.COWI..LHE"]["azimuth_deg"]["median"] == pytest.approx(
        lhn["median"] + 90.0)
    assert "assumed orthogonal" in res["meta"]["assumption"]


def test_vertical_against_vertical_with_gain_held_is_refused(sim_files, tmp_path):
    out = tmp_path / "o"
    proc = run_fit(*base_args(sim_files), "--sut-id", "XX.SIM.10.BHZ", "--ref-id",
                   "XX.SIM.00.BHZ", "--band", *SIM_BAND, "--fit-response", "none", out=out)
    assert_user_error(proc, out, "", "do not hold it with --fit-response none")


def test_vertical_against_vertical_is_not_given_azimuth_180(sim_files, tmp_path):
    out = tmp_path / "o"
    proc = run_fit(*base_args(sim_files), "--sut-id", "XX.SIM.10.BHZ", "--ref-id",
                   "XX.SIM.00.BHZ", "--band", *SIM_BAND, out=out)   # default: gain free
    assert proc.returncode == 0, proc.stderr
    az = json.loads((out / "result.json").read_text())["channels"]["XX.SIM.10.BHZ"]["azimuth_deg"]
    assert az["undefined"] and az["median"] is None and az["nominal_deg"] == 0.0
