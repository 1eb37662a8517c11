"""What a new user meets first: the demo says what it runs and installs only
the package, reruns leave nothing stale, the Python API and the consoles say
what they print (units, which interval), logs get whole lines, a pinned gain
on a one-channel pair points at a swap, documented imports work."""
from __future__ import annotations

import json
import os
import re
import subprocess
import sys
import tomllib
import warnings
from pathlib import Path

import numpy as np
import pytest

from tests.conftest import SIM_BAND

ROOT = Path(__file__).resolve().parents[1]
PY = sys.executable


def _fit(files, out, *extra, quiet=True):
    cmd = [PY, "-m", "bayescal", "fit", "--ref", str(files["ref.mseed"]), "--ref-xml",
           str(files["ref.xml"]), "--sut", str(files["sut.mseed"]), "--sut-xml",
           str(files["sut.xml"]), "--out", str(out), *map(str, extra)]
    return subprocess.run(cmd + (["--quiet"] if quiet else []), capture_output=True, text=True,
                          timeout=300, cwd=str(ROOT))


# --- the demo and the install -------------------------------------------------------

def test_license_is_an_spdx_string():
    """setuptools warns about a license given as a TOML table."""
    meta = tomllib.loads((ROOT / "pyproject.toml").read_text())
    assert meta["project"]["license"] == "BSD-3-Clause"


def test_make_demo_installs_the_package_without_the_test_extra():
    make = subprocess.run(["make", "-n", "-B", "demo", "PYTHON=python3"], capture_output=True,
                          text=True, cwd=str(ROOT)).stdout
    installs = [ln for ln in make.splitlines() if "pip install" in ln]
    assert installs and not any("[test]" in ln for ln in installs), make
    make = subprocess.run(["make", "-n", "-B", "test", "PYTHON=python3"], capture_output=True,
                          text=True, cwd=str(ROOT)).stdout
    assert any("[test]" in ln for ln in make.splitlines() if "pip install" in ln), make


def test_demo_prints_the_command_it_runs(tmp_path, capsys):
    sys.path.insert(0, str(ROOT / "examples"))
    try:
        import demo
    finally:
        sys.path.remove(str(ROOT / "examples"))
    assert demo.run(str(tmp_path), quiet=True) == 0
    out = capsys.readouterr().out
    line = next(ln for ln in out.splitlines() if ln.startswith("running: bayescal fit "))
    for part in ("--ref ", "--ref-xml ", "--sut ", "--sut-xml ", "--fit-response all",
                 "--band 0.01 1.0", f"--out {tmp_path / 'fit'}"):
        assert part in line, line


# --- reruns --------------------------------------------------------------------------

def test_rerun_removes_what_the_previous_run_wrote_and_nothing_else(sim_files, tmp_path):
    out = tmp_path / "out"
    first = _fit(sim_files, out, "--band", *SIM_BAND)
    assert first.returncode == 0, first.stderr
    assert (out / "report.pdf").is_file()
    (out / "my_notes.txt").write_text("mine")
    second = _fit(sim_files, out, "--band", 0.05, 1.0, "--no-report")
    assert second.returncode == 0, second.stderr
    names = set(os.listdir(out))
    assert not [n for n in names if n.startswith("report")], names      # the old report is gone
    assert {"result.json", "samples.npz", "my_notes.txt"} <= names
    assert json.loads((out / "result.json").read_text())["meta"]["band_hz"][0] == 0.05


# --- the Python API --------------------------------------------------------------------

def test_data_are_keywords_named_as_the_cli_options(sim_pair, sim_files):
    """A positional call (the old order put the SUT first) is refused with a
    message naming the keywords, never run with the sensors swapped."""
    from bayescal import calibrate, calibrate_files

    with pytest.raises(TypeError, match=r"ref=\.\.\., ref_xml=\.\.\., sut=\.\.\., sut_xml="):
        calibrate(sim_pair.sut, sim_pair.sut_inventory, sim_pair.ref, sim_pair.ref_inventory)
    with pytest.raises(TypeError, match="keywords"):
        calibrate_files(str(sim_files["sut.mseed"]), str(sim_files["sut.xml"]),
                        str(sim_files["ref.mseed"]), str(sim_files["ref.xml"]))
    post = calibrate_files(ref=str(sim_files["ref.mseed"]), ref_xml=str(sim_files["ref.xml"]),
                           sut=str(sim_files["sut.mseed"]), sut_xml=str(sim_files["sut.xml"]),
                           band=SIM_BAND, progress=False, fit_response="none")
    assert post.channel_ids[0].startswith("XX.SIM.10.")          # the SUT is the SUT
    # calibrate takes metadata as an Inventory or as the CLI does (a path, 'flat')
    post = calibrate(ref=sim_pair.ref, ref_xml=str(sim_files["ref.xml"]), sut=sim_pair.sut,
                     sut_xml=sim_pair.sut_inventory, band=SIM_BAND, progress=False,
                     fit_response="none")
    assert post.channel_ids[0].startswith("XX.SIM.10.")


def test_summary_is_plain_json_and_a_vertical_has_no_azimuth(sim_pair):
    from bayescal import calibrate

    post = calibrate(ref=sim_pair.ref, ref_xml=sim_pair.ref_inventory, sut=sim_pair.sut,
                     sut_xml=sim_pair.sut_inventory, band=SIM_BAND, progress=False)
    s = post.summary()
    assert json.loads(json.dumps(s, allow_nan=False)) == s       # plain values, no NaN
    z = s["channels"]["XX.SIM.10.BHZ"]
    assert z["azimuth_deg"]["median"] is None and z["azimuth_deg"]["undefined"]
    assert "tilt_deg" in z


def test_a_failed_model_check_is_a_python_warning():
    """A SUT whose natural period is 20 s where its metadata say 30 s, fitted
    with its gains only: the model check fails, and a script hears of it,
    with the criticism's verdict. A 33 % error conflicts with the sensor's
    5 % prior, so the SUT's long-period corner under its wide prior is
    named, and damping/period is measured: 0.707 / 20 inside its interval."""
    from bayescal import calibrate
    from bayescal.errors import ModelMisfitWarning
    from bayescal.simulate.pair import simulate_pair

    sim = simulate_pair(duration=3600.0, fs=10.0, seed=3, coherence=0.999,
                        sut_response=((20.0, 0.707, 750.0),) * 3)
    with pytest.warns(ModelMisfitWarning, match="MODEL DOES NOT FIT.*long-period corner"):
        post = calibrate(ref=sim.ref, ref_xml=sim.ref_inventory, sut=sim.sut,
                         sut_xml=sim.sut_inventory,
                         band=(0.02, 1.0), progress=False, min_ess=200, n_tau=20)
    s = post.summary()      # the fit's check: the rejected fit's when the improved model heads
    assert (s.get("rejected_fit") or s)["adequacy"]["ok"] is False
    effect = post.criticism["effects"][0]
    for tr in sim.sut:
        lo, hi = effect["size"][f"damping_over_period:{tr.id}"]["ci95"]
        assert lo <= 0.707 / 20.0 <= hi
        lo, hi = effect["size"][f"period_s:{tr.id}"]["ci95"]     # the band reaches the corner
        assert lo <= 20.0 <= hi
    assert effect["name"] == "sut_corner" and "set_by_prior" not in effect
    clean = simulate_pair(duration=3600.0, fs=10.0, seed=3, coherence=0.999)
    with warnings.catch_warnings():
        warnings.simplefilter("error", ModelMisfitWarning)
        calibrate(ref=clean.ref, ref_xml=clean.ref_inventory, sut=clean.sut,
                  sut_xml=clean.sut_inventory,
                  band=(0.02, 1.0), progress=False)


# --- what the consoles and reports say ---------------------------------------------------

def test_units_read_as_users_write_them():
    from bayescal.core.response.family import units_label

    assert units_label("V", "M/S") == "V/(m/s)"
    assert units_label("COUNTS", "M/S**2") == "counts/(m/s^2)"
    assert units_label("V", "M") == "V/m"


def test_cal_and_uvw_consoles_say_which_interval(capsys):
    from bayescal.cli.cal import _print_summary as cal_print
    from bayescal.cli.uvw import _print_summary as uvw_print

    e = {"median": 1.0, "ci95": [0.9, 1.1]}
    cal_print({"channel": "XX.A..BHZ", "kind": "random", "fit": "lp",
               "parameters": {"period_s": e, "gain": e, "hf_poles": [], "hf_zeros": []},
               "units": {"gain": "V/(m/s) (first stage) at 1 Hz"},
               "adequacy": {"misfit": 1.0, "p_value": 0.5}, "convergence": {"converged": True}})
    out = capsys.readouterr().out
    assert "95 %" in out and "period_s 1 [0.9, 1.1] s" in out and "[0.9, 1.1] V/(m/s)" in out
    xyz = {"gain": e, "period_s": e, "damping": e}
    uvw_print({"mode": "all-outputs", "gain_units": "V/(m/s)",
               "elements": {"U": {"period_s": e, "damping": e, "gain": e}},
               "xyz": {"X": xyz}, "cross_talk_max": e, "cross_talk_max_pair": "X-Y"})
    out = capsys.readouterr().out
    assert "95 %" in out
    x = next(ln for ln in out.splitlines() if ln.strip().startswith("X:"))
    assert x.count("[0.9, 1.1]") == 3, x


def test_flat_metadata_have_no_deviation_and_gains_carry_units(capsys):
    from bayescal.cli.fit import print_summary
    from bayescal.report.tables import response_rows

    g = {"median": 1.16e9, "ci95": [1.15e9, 1.17e9], "ci68": [1.155e9, 1.165e9]}
    summary = {"channels": {"XX.A..HHZ": {
        "azimuth_deg": {"median": None, "undefined": True}, "dip_deg": {"median": -90.0},
        "nominal": {"azimuth_deg": 0.0, "dip_deg": -90.0, "gain": 1.0,
                    "gain_units": "counts/(m/s)"},
        "response": {"gain": g, "relative_gain": g}}},
        "convergence": {"ess_min": 2000, "rhat_max": 1.0, "tau_max": 1.0, "n_steps": 300}}
    rows = response_rows(summary)
    assert [r.deviation for r in rows] == [None, None]
    assert all("no nominal" in r.note for r in rows)
    print_summary(summary)
    out = capsys.readouterr().out
    assert "counts/(m/s)" in out and "(fitted / metadata gain)" in out


def test_logs_get_whole_lines(sim_files, tmp_path):
    """Without a terminal (stderr to a pipe) no progress-bar frames pile up
    and every message starts its own line."""
    proc = _fit(sim_files, tmp_path / "o", "--band", *SIM_BAND, "--no-report", quiet=False)
    assert proc.returncode == 0, proc.stderr
    assert "\r" not in proc.stderr
    starts = ("bayescal fit:", "band used:", "data used:", "least squares:", "mode search:",
              "sampling", "criticism", "wrote ")
    for ln in proc.stderr.splitlines():
        assert ln.startswith(starts), ln


def test_examples_help_gives_the_whole_first_sentence():
    for script in sorted((ROOT / "examples").glob("*.py")):
        text = script.read_text()
        if "argparse" not in text or script.name.startswith("_"):
            continue
        helptext = subprocess.run([PY, str(script), "--help"], capture_output=True, text=True,
                                  timeout=120, cwd=str(ROOT)).stdout
        doc = " ".join(re.search(r'"""(.*?)\n\n', text, re.S).group(1).split())
        assert doc in " ".join(helptext.split()), (script.name, doc)


# --- a swap on a one-channel pair ------------------------------------------------------------

def test_pinned_gain_on_a_one_channel_pair_points_at_a_swap(tmp_path):
    """A vertical whose gain is 20 times its metadata value (as when --ref
    and --sut are given the wrong way round): the gain is pinned at its
    prior's bound, and the console says to check the metadata and the order."""
    from bayescal.simulate.pair import simulate_pair

    sim = simulate_pair(duration=1800.0, fs=10.0, seed=6, coherence=0.99,
                        sut_response=((30.0, 0.707, 20 * 750.0),) * 3)
    files = sim.write(str(tmp_path / "in"))
    proc = _fit(files, tmp_path / "o", "--band", *SIM_BAND, "--no-report", "--sut-id",
                "XX.SIM.10.BHZ", "--ref-id", "XX.SIM.00.BHZ")
    assert proc.returncode == 0, proc.stderr
    warn = [ln for ln in proc.stdout.splitlines() if ln.startswith("WARNING")]
    assert len(warn) == 1 and "--ref and --sut are swapped" in warn[0], proc.stdout
    clean = simulate_pair(duration=1800.0, fs=10.0, seed=6, coherence=0.99).write(
        str(tmp_path / "in2"))
    proc = _fit(clean, tmp_path / "o2", "--band", *SIM_BAND, "--no-report", "--sut-id",
                "XX.SIM.10.BHZ", "--ref-id", "XX.SIM.00.BHZ")
    assert proc.returncode == 0 and "swapped" not in proc.stdout, proc.stdout


# --- documentation -----------------------------------------------------------------------------

def test_every_documented_import_works():
    lines = set()
    for doc in [ROOT / "README.md", *sorted((ROOT / "docs").glob("*.md"))]:
        for ln in doc.read_text().splitlines():
            ln = ln.strip().lstrip(">").strip()
            if re.match(r"(from bayescal[\w.]* import |import bayescal)", ln):
                lines.add(ln.split("  #")[0].split(" #")[0].rstrip(","))
    assert lines
    code = "\n".join(sorted(ln for ln in lines if not ln.endswith("(")))
    proc = subprocess.run([PY, "-c", code], capture_output=True, text=True, cwd=str(ROOT))
    assert proc.returncode == 0, (code, proc.stderr)
