"""The ``bayescal fit`` command, run as a user runs it (a subprocess):
success on a simulated pair (the orientation against the simulation's truth,
the data used against the documented segment rule, the corrected StationXML
read back), and each bad-input case ending with exit code 2, one line naming
the file, no traceback and nothing written."""
from __future__ import annotations

import os
import subprocess

import numpy as np
import obspy
import pytest

from tests.cli_helpers import (PY, Z_001, assert_user_error, base_args,  # noqa: F401
                               median_mc_error, read_result, run_fit)
from tests.closed_forms import check_horizontal_azimuths
from tests.conftest import SIM_BAND, SIM_KW

HORIZONTALS = ("XX.SIM.10.BH1", "XX.SIM.10.BH2")


def expected_segments(n, fs, fmin, segment_s, nan=()):
    """Segments the fit keeps by the rule result.json states: Welch segments
    of ``segment_s`` seconds overlapping by half from the record's first
    sample; one is dropped when it comes within two periods of the band's
    lower edge ``fmin`` of the record's ends or of a missing sample (``nan``,
    sample indices). Returns (kept, possible)."""
    nper = int(round(segment_s * fs))
    step = nper // 2
    margin = int(round(2 * fs / fmin))
    bad = np.zeros(n, bool)
    bad[:margin] = bad[n - margin:] = True
    for i in np.asarray(nan, int):
        bad[max(i - margin, 0):i + margin + 1] = True
    starts = np.arange(0, n - nper + 1, step)
    kept = sum(not bad[s:s + nper].any() for s in starts)
    return int(kept), int(starts.size)


def test_fit_recovers_simulated_orientation_and_writes_everything(cli_fit, sim_pair):
    """Angles within 3.29 posterior sd of the simulation's truth (a
    two-sided level of 0.001 per angle) and measured to better than 0.15
    degree; the segments used are those the stated rule keeps on a gap-free
    record (only the ends' deconvolution transients left out); the
    corrected StationXML carries the medians."""
    out, res = cli_fit["out"], cli_fit["result"]
    for name in ("result.json", "samples.npz", "diagnostics.npz", "sut_corrected.xml"):
        assert (out / name).is_file()
    assert res["schema"] == "bayescal.fit/1"
    assert sorted(res["channels"]) == ["XX.SIM.10.BH1", "XX.SIM.10.BH2", "XX.SIM.10.BHZ"]
    truth = sim_pair.truth["channels"]
    for cid, t in truth.items():
        e = res["channels"][cid]
        checks = [("dip_deg", t["dip_deg"])]
        if cid in HORIZONTALS:
            checks.append(("azimuth_deg", t["azimuth_deg"]))
            assert e["azimuth_deg"]["sd"] < 0.15
        for key, want in checks:
            got = e[key]
            assert abs(got["median"] - want) < Z_001 * got["sd"], (cid, key, got, want)
    used = res["meta"]["data_used"]
    n = int(round(SIM_KW["duration"] * SIM_KW["fs"]))
    kept, possible = expected_segments(n, SIM_KW["fs"], SIM_BAND[0], res["meta"]["segment_s"])
    assert (used["segments"], used["segments_possible"]) == (kept, possible)
    inv = obspy.read_inventory(str(out / "sut_corrected.xml"))
    for cid, e in res["channels"].items():
        ch = inv.select(channel=cid.split(".")[-1])[0][0][0]
        if cid in HORIZONTALS:
            assert ch.azimuth == pytest.approx(e["azimuth_deg"]["median"] % 360, abs=1e-9)
        assert ch.dip == pytest.approx(e["dip_deg"]["median"], abs=1e-9)
        g = e["response"]["gain"]["median"]
        assert ch.response.response_stages[0].stage_gain == pytest.approx(g, rel=1e-9)
        # flat digitizer and the pendulum normalised at 1 Hz: sensitivity = gain x 4e5
        assert ch.response.instrument_sensitivity.value == pytest.approx(g * 4.0e5, rel=1e-6)


def test_refit_with_the_corrected_stationxml_finds_nothing_to_correct(cli_fit, sim_files,
                                                                     tmp_path):
    """The corrected StationXML read back: the same recordings fitted again
    with ``sut_corrected.xml`` as ``--sut-xml`` give relative gains of 1 and
    angles equal to the metadata's, within the Monte Carlo error of two
    medians (two-sided level 0.001 per number). A corrected file that lost
    a value, its sign, or its unit would leave that deviation."""
    first = cli_fit["result"]
    corrected = cli_fit["out"] / "sut_corrected.xml"
    out = tmp_path / "refit"
    proc = run_fit(*base_args(sim_files, **{"--sut-xml": corrected}), "--band", *SIM_BAND,
                   "--seed", 5, out=out)
    assert proc.returncode == 0, proc.stderr
    res = read_result(out)
    ess = min(first["convergence"]["ess_min"], res["convergence"]["ess_min"])
    inv = obspy.read_inventory(str(corrected))
    for cid, e in res["channels"].items():
        ch = inv.select(channel=cid.split(".")[-1])[0][0][0]
        assert e["nominal"]["dip_deg"] == pytest.approx(ch.dip, abs=1e-9)
        checks = [("dip_deg", ch.dip)]
        if cid in HORIZONTALS:
            assert e["nominal"]["azimuth_deg"] == pytest.approx(ch.azimuth, abs=1e-9)
            checks.append(("azimuth_deg", ch.azimuth))
        for key, meta in checks:
            got = e[key]
            dev = (got["median"] - meta + 180.0) % 360.0 - 180.0
            tol = Z_001 * np.sqrt(2) * median_mc_error(got, ess)
            assert abs(dev) < tol, (cid, key, dev, tol)
        rel = e["response"]["relative_gain"]
        tol = Z_001 * np.sqrt(2) * median_mc_error(rel, ess)
        assert abs(rel["median"] - 1.0) < tol, (cid, rel, tol)
        assert e["nominal"]["gain"] == pytest.approx(
            first["channels"][cid]["response"]["gain"]["median"], rel=1e-9)


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
    assert "chosen from the data" in proc.stdout     # "band used: ..." with the results
    res = read_result(out)
    lo, hi = res["meta"]["band_hz"]
    assert 0 < lo < hi <= 5.0
    assert "chosen from the data" in res["meta"]["band_choice"]
    assert len(res["meta"]["files"]["sut"]) == 3
    # median within 3.29 sd of the truth, sd between the closed-form bounds
    check_horizontal_azimuths(res, sim_pair, (lo, hi), cids=("XX.SIM.10.BH1",))


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
    """A one-minute transient that saturates BH1: a warning naming the file,
    and exactly the segments the stated rule drops around the clipped
    samples (they become gaps) are left out, against the clean record's."""
    st = obspy.read(str(sim_files["sut.mseed"]))
    x = st[0].data.astype(float)
    x[20000:20600] *= 50.0          # a one-minute transient that saturates
    lim = 0.3 * np.abs(x).max()
    st[0].data = np.clip(x, -lim, lim)
    clipped_at = np.flatnonzero(np.abs(st[0].data) >= lim)
    clipped = tmp_path / "clipped.mseed"
    st.write(str(clipped), format="MSEED", encoding="FLOAT64")
    out = tmp_path / "o"
    proc = run_fit(*base_args(sim_files, **{"--sut": clipped}), "--band", *SIM_BAND, out=out)
    assert proc.returncode == 0, proc.stderr
    assert "warning" in proc.stderr and "clipped" in proc.stderr and "clipped.mseed" in proc.stderr
    res = read_result(out)
    used = res["meta"]["data_used"]
    n = st[0].stats.npts
    args = (n, SIM_KW["fs"], SIM_BAND[0], res["meta"]["segment_s"])
    clean, possible = expected_segments(*args)
    kept, _ = expected_segments(*args, nan=clipped_at)
    assert kept < clean
    assert (used["segments"], used["segments_possible"]) == (kept, possible)


def test_existing_output_folder_keeps_other_files(sim_files, tmp_path):
    out = tmp_path / "o"
    out.mkdir()
    (out / "notes.txt").write_text("mine")
    proc = run_fit(*base_args(sim_files, **{"--sut": tmp_path / "missing.mseed"}), out=out)
    assert proc.returncode == 2
    assert sorted(os.listdir(out)) == ["notes.txt"]


# --- every interval against its label -------------------------------------------------------
def test_result_json_intervals_are_those_of_the_written_samples(cli_fit):
    """Each median, sd and 68/90/95 % interval of result.json (angles, tilt
    components, gains, relative gains, the angle between the horizontals)
    is the equal-tailed percentile pair its label names, of the samples in
    samples.npz; the vertical's tilt and dip are the range over its
    elliptical lean region at that level (tests/intervals.py). Bound: float
    rounding (1e-9), the same samples read back."""
    from tests.intervals import assert_fit_folder
    # BH1, BH2: azimuth, dip; BHZ: tilt, dip, lean north, lean east; 3 gains, 3
    # relative gains; the angle between BH1 and BH2
    assert assert_fit_folder(cli_fit["out"]) == 15


_CI = r"(-?\d+\.\d{3}) \[(-?\d+\.\d{3}), (-?\d+\.\d{3})\]"


def console_rows(stdout):
    """``{(channel or pair, quantity): (median, lo, hi)}`` of the console
    table of ``bayescal fit`` (three decimals; a tilt given as an upper
    bound has lo None)."""
    import re
    rows, cid = {}, None
    for line in stdout.splitlines():
        head = re.match(r"(\S+)\s+(.*)$", line)
        if line.startswith("angle "):
            pair = line.split()[1]
            rows[pair, "orthogonality"] = tuple(map(float, re.search(_CI, line).groups()))
        elif head and head.group(1).startswith("XX."):
            cid = head.group(1)
            cells = re.findall(_CI, head.group(2))
            names = ["azimuth", "dip"] if len(cells) == 2 else ["dip"]
            for name, c in zip(names, cells):
                rows[cid, name] = tuple(map(float, c))
        elif cid and line.startswith(" " * 22):
            text = line.strip()
            bound = re.match(r"tilt < (-?\d+\.\d{3}) deg, 95 %", text)
            if bound:
                rows[cid, "tilt"] = (None, None, float(bound.group(1)))
            elif text.startswith("tilt "):
                rows[cid, "tilt"] = tuple(map(float, re.search(_CI, text).groups()))
            else:
                m = re.match(r"(\w+) " + _CI, text)
                if m:
                    rows[cid, m.group(1)] = tuple(map(float, m.groups()[1:]))
        elif not line.strip():
            cid = None
    return rows


def test_console_95_percent_columns_are_those_of_the_written_samples(cli_fit):
    """The console's ``[95%]`` columns (azimuth, dip, the vertical's tilt,
    gains, relative gains, the angle between the horizontals) are the 2.5
    and 97.5 % percentiles of samples.npz (the tilt and the vertical's dip:
    the range over the 95 % lean region), and the medians the 50 %. Bound:
    half the last printed decimal (0.0005) plus float rounding (a tilt
    region's: tests/intervals.region_tolerance)."""
    from tests.intervals import FLOAT, equal_tailed, fit_samples, region_interval
    _, samples = fit_samples(cli_fit["out"])
    rows = console_rows(cli_fit["proc"].stdout)
    names = {("azimuth_deg",): "azimuth", ("dip_deg",): "dip", ("tilt_deg",): "tilt",
             ("orthogonality",): "orthogonality", ("response", "gain"): "gain",
             ("response", "relative_gain"): "relative_gain"}
    checked = 0
    for (key, path), x in samples.items():
        if path not in names:
            continue
        med, lo, hi = rows[key, names[path]]
        if isinstance(x, tuple):
            (want_lo, want_hi), tol = region_interval(x[1], "ci95", dip=path == ("dip_deg",))
            want_med = float(np.median(x[2]))
        else:
            e = equal_tailed(x, ("ci95",))
            (want_lo, want_hi), want_med, tol = e["ci95"], e["median"], FLOAT
        got = [v for v in (med, lo, hi) if v is not None]
        want = [w for v, w in zip((med, lo, hi), (want_med, want_lo, want_hi)) if v is not None]
        np.testing.assert_allclose(got, want, rtol=0, atol=0.0005 + tol,
                                   err_msg=f"{key} {names[path]}: {cli_fit['proc'].stdout}")
        checked += 1
    assert checked == 13, (checked, rows)


def test_an_entry_without_a_value_prints_as_a_dash_not_a_format_error():
    """A summary entry whose median is None (an angle the data leave
    undefined) prints as a dash with its reason; a valued one with its
    interval."""
    from bayescal.cli.fit import _fmt
    assert _fmt({"median": None, "note": "near-vertical channel: azimuth is not constrained"}) \
        == "- (near-vertical channel)"
    assert _fmt({"median": 1.0, "ci95": [0.5, 1.5]}) == "1.000 [0.500, 1.500]"
