"""Inputs a new user gets wrong, or needs: channel choice by SEED-id
pattern, the same file as both sensors, a StationXML epoch that misses the
data, and --start/--end windows that cannot work. Each ends in one line
naming the right thing, exit code 2."""
from __future__ import annotations

import obspy
import pytest

from tests.cli_helpers import Z_001, assert_user_error, base_args, run_fit


def test_channels_chosen_by_seed_id_pattern(cli_fit, sim_pair):
    """The shared run reads both sensors from one file, each chosen by a
    SEED-id pattern (the reference's in lower case): the SUT's three
    channels are fitted against the reference's, and BH1's azimuth lies
    within 3.29 posterior sd of the truth (two-sided level 0.001)."""
    res = cli_fit["result"]
    assert sorted(res["channels"]) == ["XX.SIM.10.BH1", "XX.SIM.10.BH2", "XX.SIM.10.BHZ"]
    assert sorted(res["meta"]["reference"]) == ["XX.SIM.00.BHE", "XX.SIM.00.BHN",
                                                "XX.SIM.00.BHZ"]
    truth = sim_pair.truth["channels"]["XX.SIM.10.BH1"]["azimuth_deg"]
    az = res["channels"]["XX.SIM.10.BH1"]["azimuth_deg"]
    assert abs(az["median"] - truth) < Z_001 * az["sd"] and az["sd"] < 0.15


def test_pattern_matching_nothing_names_the_file_and_its_ids(sim_files, both_sensors,
                                                             tmp_path):
    out = tmp_path / "o"
    proc = run_fit("--ref", both_sensors, "--ref-xml", sim_files["ref.xml"],
                   "--sut", both_sensors, "--sut-xml", sim_files["sut.xml"],
                   "--sut-id", "XX.SIM.20.*", "--ref-id", "XX.SIM.00.*", out=out)
    assert_user_error(proc, out, "both.mseed", "no SUT channel matches XX.SIM.20.*")
    assert "XX.SIM.10.BH1" in proc.stderr


def test_one_file_holding_both_sensors_without_choice_is_refused(sim_files, both_sensors,
                                                                 tmp_path):
    out = tmp_path / "o"
    proc = run_fit("--ref", both_sensors, "--ref-xml", sim_files["ref.xml"],
                   "--sut", both_sensors, "--sut-xml", sim_files["sut.xml"], out=out)
    assert_user_error(proc, out, "both.mseed", "--sut-id")


def test_same_file_as_reference_and_sut_is_refused(sim_files, tmp_path):
    out = tmp_path / "o"
    proc = run_fit(*base_args(sim_files, **{"--ref": sim_files["sut.mseed"],
                                            "--ref-xml": sim_files["sut.xml"]}), out=out)
    assert_user_error(proc, out, "sut.mseed", "given as both reference and SUT")


def test_stationxml_epoch_not_covering_the_data_says_so(sim_files, tmp_path):
    inv = obspy.read_inventory(str(sim_files["sut.xml"]))
    for ch in inv[0][0]:
        ch.start_date = obspy.UTCDateTime(2030, 1, 1)
    xml = tmp_path / "late_epoch.xml"
    inv.write(str(xml), format="STATIONXML")
    out = tmp_path / "o"
    proc = run_fit(*base_args(sim_files, **{"--sut-xml": xml}), out=out)
    assert_user_error(proc, out, "late_epoch.xml", "no epoch covers the data")
    assert "2030-01-01" in proc.stderr


def test_start_after_end(sim_files, tmp_path):
    out = tmp_path / "o"
    st = obspy.read(str(sim_files["sut.mseed"]))[0].stats.starttime
    proc = run_fit(*base_args(sim_files), "--start", st + 600, "--end", st + 300, out=out)
    assert_user_error(proc, out, "--start", "is not before --end")


def test_window_outside_the_data_names_the_waveform_files(sim_files, tmp_path):
    out = tmp_path / "o"
    st = obspy.read(str(sim_files["sut.mseed"]))[0].stats.starttime
    proc = run_fit(*base_args(sim_files), "--start", st + 86400, out=out)
    assert_user_error(proc, out, "sut.mseed", "lies outside")
    assert "ref.mseed" in proc.stderr and ".xml" not in proc.stderr


def test_batch_plan_carries_channel_patterns(tmp_path):
    from bayescal.network.plan import read_csv_plan

    plan = tmp_path / "plan.csv"
    plan.write_text("label,ref,ref_xml,sut,sut_xml,sut_id,ref_id\n"
                    "a,both.mseed,ref.xml,both.mseed,sut.xml,XX.SIM.10.BH?,XX.SIM.00.BHN;"
                    "XX.SIM.00.BHE\n")
    item = read_csv_plan(str(plan))[0]
    assert item["sut_id"] == ["XX.SIM.10.BH?"]
    assert item["ref_id"] == ["XX.SIM.00.BHN", "XX.SIM.00.BHE"]
