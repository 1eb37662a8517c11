"""What the commands print and write for a user: one-line errors naming the
file and what was searched, units that say what the numbers are, the
report command on every kind of output folder, simulated channels named
by the SEED band code of their rate, and the co-located simulation's truth."""
from __future__ import annotations

import json

import numpy as np
import pytest

from bayescal.cli import main


@pytest.mark.parametrize("fs, code", [(5000.0, "F"), (1000.0, "F"), (500.0, "C"), (100.0, "H"),
                                      (80.0, "H"), (40.0, "B"), (10.0, "B"), (5.0, "M"),
                                      (2.0, "M"), (1.0, "L"), (0.5, "L"), (0.1, "V"),
                                      (0.01, "U")])
def test_band_code_is_seeds_for_a_broadband(fs, code):
    """SEED manual, Appendix A (band codes for a corner period of 10 s or more)."""
    from bayescal.simulate.pair import band_code
    assert band_code(fs) == code


def test_simulated_cal_run_at_5_hz_is_mhz_and_a_wrong_input_channel_lists_all(tmp_path, capsys):
    from bayescal.simulate.cal import simulate_random_cal
    sim = simulate_random_cal(duration=600.0, fs=5.0, seed=1)
    paths = sim.write(str(tmp_path / "run"))
    assert [tr.stats.channel for tr in sim.runs["cal"]] == ["BC0", "MHZ"]
    assert sim.truth["channel"] == "XX.CAL.00.MHZ"
    assert sim.inventory.select(channel="MHZ")[0][0][0].sample_rate == 5.0
    rc = main(["cal", "--cal", paths["cal"], "--input-channel", "BX0", "--output-channel", "MHZ",
               "--sut-xml", paths["xml"], "--coil-constant", "1e-9",
               "--out", str(tmp_path / "out")])
    err = capsys.readouterr().err
    assert rc == 2 and len(err.strip().splitlines()) == 1
    assert err.startswith(f"bayescal: error: {paths['cal']}: no input channel BX0 ")
    assert err.rstrip().endswith("XX.CAL.00.BC0, XX.CAL.00.MHZ")
    assert not (tmp_path / "out").exists()


def test_colocated_simulation_writes_its_truth(tmp_path):
    """truth.json beside the recordings: each sensor's self-noise as the
    module states it (sensor 00 white in acceleration at -185 dB; sensor
    10 white in velocity, -190 dB at 1 Hz rising 20 dB per decade) at
    the periods it lists, for the SEED ids written."""
    import obspy

    from bayescal.simulate.selfnoise import simulate_colocated
    data, _ = simulate_colocated(duration=600.0, fs=10.0, seed=0).write(str(tmp_path))
    truth = json.loads((tmp_path / "truth.json").read_text())
    ids = [obspy.read(p)[0].id for p in data]
    assert sorted(truth["sensors"]) == sorted(ids)
    period = np.array(truth["period_s"])
    assert period[0] == pytest.approx(0.25) and period[-1] == pytest.approx(60.0)
    np.testing.assert_allclose(truth["sensors"]["XS.SIM.00.BHZ"]["noise_psd_db"], -185.0,
                               atol=1e-3)
    np.testing.assert_allclose(truth["sensors"]["XS.SIM.10.BHZ"]["noise_psd_db"],
                               -190.0 - 20 * np.log10(period), atol=1e-3)
    assert truth["units"] == "dB re 1 (m/s^2)^2/Hz" and truth["seed"] == 0


def _noise_doc(flat):
    band = {"period_s": [1.0, 5.0], "psd_db": -7.1, "ci90_db": [-8.0, -6.2],
            "below_resolution": False}
    ids = ["XF.A..BHZ", "XF.B..BHZ", "XF.C..BHZ"]
    return {"sensors": {c: {"component": "Z", "period_bands": [band]} for c in ids},
            "meta": {"level": 0.9, "flat_metadata": flat}}


def test_noise_table_says_counts_for_flat_metadata():
    from bayescal.cli.noise import FLAT_UNIT, GROUND_UNIT, summary_lines
    flat = summary_lines(_noise_doc(["XF.A..BHZ", "XF.B..BHZ", "XF.C..BHZ"]))
    assert flat[0].startswith("self-noise, dB re 1 (count/s)^2/Hz,") and "m/s^2" not in flat[0]
    assert "-7.1 [-8.0, -6.2]" in flat[3]
    mixed = summary_lines(_noise_doc(["XF.C..BHZ"]))
    assert mixed[0].startswith(f"self-noise, {GROUND_UNIT},")
    assert mixed[-1].startswith(f"flat metadata: XF.C..BHZ: their columns are in {FLAT_UNIT}")
    assert summary_lines(_noise_doc([]))[-1].split()[0] == "1-5"     # no flat line


def test_report_on_a_folder_without_outputs_names_what_it_looks_for(tmp_path, capsys):
    rc = main(["report", str(tmp_path)])
    err = capsys.readouterr().err
    assert rc == 2 and len(err.strip().splitlines()) == 1
    for name, command in (("result.json", "fit"), ("cal.json", "cal"), ("uvw.json", "uvw"),
                          ("noise.json", "noise"), ("results.csv", "batch")):
        assert name in err and f"bayescal {command}" in err


def test_report_redraws_a_batch_folder(tmp_path, capsys):
    from bayescal.report import batch as rb
    from tests.test_cli_batch_flags import ROWS
    rb._write_csv(str(tmp_path / "results.csv"), rb.COLUMNS, ROWS)
    assert main(["report", str(tmp_path)]) == 0
    assert f"report: {tmp_path / 'report.pdf'}" in capsys.readouterr().out
    assert (tmp_path / "report.pdf").stat().st_size > 0
    assert (tmp_path / "flags.csv").read_text().count("off_nominal") == 2


def test_written_leaves_out_the_manifest(tmp_path):
    from bayescal.atomic import MANIFEST
    from bayescal.cli.common import written
    for name in ("result.json", MANIFEST, "report.pdf"):
        (tmp_path / name).write_text("x")
    assert written(str(tmp_path)) == ["report.pdf", "result.json"]
