"""The ``bayescal fit`` command, run as a user runs it (a subprocess):
success on a simulated pair, and each bad-input case ending with exit code
2, one line naming the file, no traceback and nothing written."""
from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import obspy
import pytest

from tests.conftest import SIM_BAND

PY = sys.executable


def run_fit(*args, out):
    cmd = [PY, "-m", "bayescal.cli", "fit", *map(str, args), "--out", str(out), "--quiet",
           "--no-report"]
    return subprocess.run(cmd, capture_output=True, text=True, timeout=300)


def base_args(f, **over):
    a = {"--ref": f["ref.mseed"], "--ref-xml": f["ref.xml"], "--sut": f["sut.mseed"],
         "--sut-xml": f["sut.xml"]}
    a.update(over)
    return [x for k, v in a.items() for x in (k, v)]


def assert_user_error(proc, out, name, what):
    assert proc.returncode == 2, proc.stderr
    lines = [ln for ln in proc.stderr.strip().splitlines() if not ln.startswith("bayescal: warn")]
    assert len(lines) == 1, proc.stderr
    assert lines[0].startswith("bayescal: error:")
    assert "Traceback" not in proc.stderr
    assert name in lines[0], lines[0]
    assert what in lines[0], lines[0]
    assert not Path(out).exists()
    assert not [p for p in Path(out).parent.iterdir() if ".tmp-" in p.name]


def test_fit_recovers_simulated_orientation_and_writes_everything(sim_files, sim_pair, tmp_path):
    out = tmp_path / "out"
    proc = run_fit(*base_args(sim_files), "--band", *SIM_BAND, "--seed", 3, out=out)
    assert proc.returncode == 0, proc.stderr
    for name in ("result.json", "samples.npz", "diagnostics.npz", "sut_corrected.xml"):
        assert (out / name).is_file()
    res = json.loads((out / "result.json").read_text())
    assert res["schema"] == "bayescal.fit/1"
    truth = sim_pair.truth["channels"]
    for cid in ("XX.SIM.10.BH1", "XX.SIM.10.BH2"):
        az = res["channels"][cid]["azimuth_deg"]
        assert abs(az["median"] - truth[cid]["azimuth_deg"]) < 3 * az["sd"] and az["sd"] < 0.15
        assert az["ci95"][0] - 0.05 < truth[cid]["azimuth_deg"] < az["ci95"][1] + 0.05
    # gap-free record: only segments within two periods of the band's lower
    # edge from the record's ends (the deconvolution transient) are left out
    assert 0.9 < res["meta"]["data_used"]["fraction"] < 1.0
    inv = obspy.read_inventory(str(out / "sut_corrected.xml"))
    ch = inv.select(channel="BH2")[0][0][0]
    assert ch.azimuth == pytest.approx(res["channels"]["XX.SIM.10.BH2"]["azimuth_deg"]["median"])


def test_fit_without_band_chooses_and_reports_it(sim_files, sim_pair, tmp_path):
    """Also: the SUT given as one file per channel (several files per side)."""
    out = tmp_path / "auto"
    parts = []
    for tr in obspy.read(str(sim_files["sut.mseed"])):
        parts.append(tmp_path / f"{tr.stats.channel}.mseed")
        tr.write(str(parts[-1]), format="MSEED", encoding="FLOAT64")
    args = [str(x) for x in base_args(sim_files) if str(x) != str(sim_files["sut.mseed"])]
    i = args.index("--sut")
    args[i + 1:i + 1] = [str(p) for p in parts]
    cmd = [PY, "-m", "bayescal.cli", "fit", *args, "--out", str(out), "--no-report"]
    proc = subprocess.run(cmd, capture_output=True, text=True, timeout=300)
    assert proc.returncode == 0, proc.stderr
    assert "chosen from the data" in proc.stderr
    res = json.loads((out / "result.json").read_text())
    lo, hi = res["meta"]["band_hz"]
    assert 0 < lo < hi <= 5.0
    assert "chosen from the data" in res["meta"]["band_choice"]
    assert len(res["meta"]["files"]["sut"]) == 3
    truth = sim_pair.truth["channels"]["XX.SIM.10.BH1"]["azimuth_deg"]
    az = res["channels"]["XX.SIM.10.BH1"]["azimuth_deg"]
    assert abs(az["median"] - truth) < 3 * az["sd"] and az["sd"] < 0.15


def test_help_and_version():
    out = subprocess.run([PY, "-m", "bayescal.cli", "fit", "--help"], capture_output=True,
                         text=True)
    assert out.returncode == 0
    for word in ("--ref", "--sut-xml", "--fit-response", "--band", "sut_corrected.xml"):
        assert word in out.stdout
    v = subprocess.run([PY, "-m", "bayescal.cli", "--version"], capture_output=True, text=True)
    assert v.returncode == 0 and "bayescal" in v.stdout


# --- bad input -----------------------------------------------------------------
def test_missing_file(sim_files, tmp_path):
    out = tmp_path / "o"
    missing = tmp_path / "nope.mseed"
    proc = run_fit(*base_args(sim_files, **{"--sut": missing}), out=out)
    assert_user_error(proc, out, "nope.mseed", "not found")


def test_unreadable_files(sim_files, tmp_path):
    junk = tmp_path / "junk.mseed"
    junk.write_text("garbage\n")
    out = tmp_path / "o"
    assert_user_error(run_fit(*base_args(sim_files, **{"--ref": junk}), out=out), out,
                      "junk.mseed", "ObsPy can read")
    assert_user_error(run_fit(*base_args(sim_files, **{"--sut-xml": junk}), out=out), out,
                      "junk.mseed", "StationXML")


def test_no_time_overlap(sim_files, tmp_path):
    st = obspy.read(str(sim_files["ref.mseed"]))
    for tr in st:
        tr.stats.starttime += 86400 * 3
    late = tmp_path / "late.mseed"
    st.write(str(late), format="MSEED")
    out = tmp_path / "o"
    assert_user_error(run_fit(*base_args(sim_files, **{"--ref": late}), out=out), out,
                      "late.mseed", "do not overlap")


def _inventory_variant(sim_files, tmp_path, change):
    inv = obspy.read_inventory(str(sim_files["sut.xml"]))
    change(inv)
    path = tmp_path / "variant.xml"
    inv.write(str(path), format="STATIONXML")
    return path


def test_channel_missing_from_stationxml(sim_files, tmp_path):
    def drop(inv):
        inv[0][0].channels = [c for c in inv[0][0] if c.code != "BH2"]
    xml = _inventory_variant(sim_files, tmp_path, drop)
    out = tmp_path / "o"
    assert_user_error(run_fit(*base_args(sim_files, **{"--sut-xml": xml}), out=out), out,
                      "variant.xml", "BH2 is not in the StationXML")


def test_no_response(sim_files, tmp_path):
    def strip(inv):
        inv[0][0][0].response = None
    xml = _inventory_variant(sim_files, tmp_path, strip)
    out = tmp_path / "o"
    assert_user_error(run_fit(*base_args(sim_files, **{"--sut-xml": xml}), out=out), out,
                      "variant.xml", "no response")


@pytest.mark.parametrize("kind,what", [("nan", "no valid sample"), ("zero", "all zeros")])
def test_nan_or_zero_data(sim_files, tmp_path, kind, what):
    st = obspy.read(str(sim_files["sut.mseed"]))
    st[1].data = (np.full(st[1].stats.npts, np.nan) if kind == "nan"
                  else np.zeros(st[1].stats.npts))
    bad = tmp_path / f"{kind}.mseed"
    st.write(str(bad), format="MSEED", encoding="FLOAT64")
    out = tmp_path / "o"
    assert_user_error(run_fit(*base_args(sim_files, **{"--sut": bad}), "--band", *SIM_BAND,
                              out=out), out, f"{kind}.mseed", what)


def test_too_little_data_for_the_band(sim_files, tmp_path):
    out = tmp_path / "o"
    proc = run_fit(*base_args(sim_files), "--band", 0.0005, 0.01, out=out)
    assert_user_error(proc, out, "sut.mseed", "too little data")


def test_clipped_data_warns_and_still_fits(sim_files, tmp_path):
    st = obspy.read(str(sim_files["sut.mseed"]))
    x = st[0].data.astype(float)
    x[20000:20600] *= 50.0          # a one-minute transient that saturates
    lim = 0.3 * np.abs(x).max()
    st[0].data = np.clip(x, -lim, lim)
    clipped = tmp_path / "clipped.mseed"
    st.write(str(clipped), format="MSEED", encoding="FLOAT64")
    out = tmp_path / "o"
    proc = run_fit(*base_args(sim_files, **{"--sut": clipped}), "--band", *SIM_BAND, out=out)
    assert proc.returncode == 0, proc.stderr
    assert "warning" in proc.stderr and "clipped" in proc.stderr and "clipped.mseed" in proc.stderr
    res = json.loads((out / "result.json").read_text())
    assert res["meta"]["data_used"]["fraction"] < 1.0


def test_existing_output_folder_keeps_other_files(sim_files, tmp_path):
    out = tmp_path / "o"
    out.mkdir()
    (out / "notes.txt").write_text("mine")
    proc = run_fit(*base_args(sim_files, **{"--sut": tmp_path / "missing.mseed"}), out=out)
    assert proc.returncode == 2
    assert sorted(os.listdir(out)) == ["notes.txt"]
