"""A record cut into windows and combined (:mod:`bayescal.record.windows`,
:mod:`bayescal.record.values`) and ``bayescal windows`` on a small
simulated pair whose SUT is turned by a known angle."""
from __future__ import annotations

import csv
import json

import numpy as np
import pytest

#: The pair: SUT azimuths 3 and 93 degrees, three windows of 300 s.
TRUTH = {"MH1": 3.0, "MH2": 93.0}
WINDOW = 300.0


@pytest.fixture(scope="module")
def pair():
    from bayescal.simulate import simulate_pair
    return simulate_pair(duration=3 * WINDOW, fs=2.0, seed=5, coherence=0.999,
                         sut_azimuth=(TRUTH["MH1"], TRUTH["MH2"], 0.0))


@pytest.fixture(scope="module")
def files(pair, tmp_path_factory):
    return pair.write(str(tmp_path_factory.mktemp("windows_pair")))


def test_window_edges_leave_out_a_last_partial_window():
    from obspy import UTCDateTime

    from bayescal.record.windows import window_edges
    t = UTCDateTime(2026, 1, 1)
    edges = window_edges(t, t + 1799.5, 600.0)
    assert [(a - t, b - t) for a, b in edges] == [(0.0, 600.0), (600.0, 1200.0)]
    assert len(window_edges(t, t + 1800.0, 600.0)) == 3


def test_windows_writes_the_record_and_holds_the_truth(files, tmp_path, capsys):
    """Exit 0; windows.csv has a row per window and parameter; record.json's
    record values of both azimuths hold the simulated truth; each window's
    interval for the record's value holds its own 95 % interval's median."""
    from bayescal.cli import main
    out = tmp_path / "rec"
    code = main(["windows", "--ref", files["ref.mseed"], "--ref-xml", files["ref.xml"],
                 "--sut", files["sut.mseed"], "--sut-xml", files["sut.xml"], "--band", "0.1",
                 "0.8", "--window", str(WINDOW), "--out", str(out), "--quiet", "--no-report"])
    assert code == 0
    doc = json.loads((out / "record.json").read_text())
    assert doc["fitted"] == 3 and doc["skipped"] == []
    for ch, truth in TRUTH.items():
        mu = doc["parameters"][f"XX.SIM.10.{ch}:azimuth_deg"]["mu"]
        assert mu["ci95"][0] <= truth <= mu["ci95"][1], (ch, mu)
    rows = list(csv.DictReader((out / "windows.csv").open()))
    assert len(rows) == 3 * len(doc["parameters"])
    for r in rows:
        assert float(r["record_ci95_low"]) <= float(r["median"]) <= float(r["record_ci95_high"])
    printed = capsys.readouterr().out
    assert "XX.SIM.10.MH1:azimuth_deg" in printed and "ratio without / with" in printed


def test_a_window_with_a_gap_is_skipped_with_its_reason(pair):
    """A gap over the second window: it is listed with the fit's reason and
    the two others are fitted."""
    from bayescal.record import fit_windows
    sut = pair.sut.copy()
    t0 = sut[0].stats.starttime
    sut.cutout(t0 + WINDOW + 10, t0 + 2 * WINDOW - 10)
    ws = fit_windows(ref=pair.ref, ref_xml=pair.ref_inventory, sut=sut,
                     sut_xml=pair.sut_inventory, window=WINDOW, band=(0.1, 0.8), diagnose=False)
    assert [w.fitted for w in ws] == [True, False, True]
    assert "segment" in ws[1].reason or "data" in ws[1].reason, ws[1].reason


@pytest.mark.parametrize("extra, words", [(["--window", "0"], "positive number of seconds"),
                                          (["--window", "5000"], "no whole window")])
def test_bad_input_is_one_line_exit_2_and_nothing_written(files, tmp_path, capsys, extra, words):
    from bayescal.cli import main
    out = tmp_path / "never"
    code = main(["windows", "--ref", files["ref.mseed"], "--ref-xml", files["ref.xml"],
                 "--sut", files["sut.mseed"], "--sut-xml", files["sut.xml"], "--band", "0.1",
                 "0.8", "--out", str(out), "--quiet", *extra])
    err = capsys.readouterr().err.strip().splitlines()
    assert code == 2 and len(err) == 1 and words in err[0], err
    assert not out.exists()


def test_azimuths_near_north_are_combined_across_360():
    """Windows at 359.9 and 0.1 degrees: the record's value is near 0 (or
    360), not 180."""
    from obspy import UTCDateTime

    from bayescal.record import combine
    from bayescal.record.windows import Window
    rng = np.random.default_rng(3)
    t = UTCDateTime(2026, 1, 1)
    ws = []
    for k, m in enumerate([359.9, 0.1, 359.95, 0.05]):
        draws = (m + 0.1 * rng.standard_normal(2000)) % 360.0
        entry = {"median": m, "ci68": [m - 0.1, m + 0.1], "ci95": [m - 0.2, m + 0.2]}
        ws.append(Window(t + 600 * k, t + 600 * (k + 1), {"X:azimuth_deg": entry},
                         {"X:azimuth_deg": draws}))
    rec = combine(ws)["X:azimuth_deg"]
    assert abs((rec.fit.mu["median"] + 180.0) % 360.0 - 180.0) < 0.2


def test_gaussian_windows_learn_the_factor_on_their_sds(files, tmp_path, capsys):
    """--window-likelihood gaussian: the windows fitted with the Gaussian
    likelihood (their own intervals differ from the per-band fit's), the
    factor on their sds learned (its 95 % interval not the fixed [1, 1], and
    holding 1: the simulated pair's noise is what the Gaussian fit assumes),
    the record values hold the simulated truth."""
    from bayescal.cli import main
    base = ["windows", "--ref", files["ref.mseed"], "--ref-xml", files["ref.xml"],
            "--sut", files["sut.mseed"], "--sut-xml", files["sut.xml"], "--band", "0.1",
            "0.8", "--window", str(WINDOW), "--quiet", "--no-report"]
    rows = {}
    for kind in ("per-band", "gaussian"):
        out = tmp_path / kind
        assert main(base + ["--out", str(out), "--window-likelihood", kind]) == 0
        rows[kind] = list(csv.DictReader((out / "windows.csv").open()))
    doc = json.loads((tmp_path / "gaussian" / "record.json").read_text())
    assert doc["window_likelihood"] == "gaussian"
    for ch, truth in TRUTH.items():
        p = doc["parameters"][f"XX.SIM.10.{ch}:azimuth_deg"]
        assert p["mu"]["ci95"][0] <= truth <= p["mu"]["ci95"][1], (ch, p["mu"])
        # the factor's prior starts at 1: its interval starts there when it holds 1
        assert p["scale"]["ci95"][0] <= 1.0 < p["scale"]["ci95"][1], p["scale"]
    own = [(r["ci95_low"], r["ci95_high"]) for r in rows["gaussian"]]
    assert own != [(r["ci95_low"], r["ci95_high"]) for r in rows["per-band"]]
    assert "sd factor [95%]" in capsys.readouterr().out


def _azimuth_windows(medians, sds, seed=3):
    from obspy import UTCDateTime

    from bayescal.record.windows import Window
    rng = np.random.default_rng(seed)
    t = UTCDateTime(2026, 1, 1)
    ws = []
    for k, (m, s) in enumerate(zip(medians, sds)):
        draws = (m + s * rng.standard_normal(2000)) % 360.0
        entry = {"median": m, "ci68": [m - s, m + s], "ci95": [m - 2 * s, m + 2 * s]}
        ws.append(Window(t + 600 * k, t + 600 * (k + 1), {"X:azimuth_deg": entry},
                         {"X:azimuth_deg": draws}))
    return ws


def test_a_stray_first_window_does_not_split_the_others_at_360():
    """Five windows near 90 degrees after a first at 270: the five stay
    together near 90 (the windows are taken about their circular mean, not
    about the first one's, which would put 89.9 at 449.9)."""
    from bayescal.record import combine
    ws = _azimuth_windows([270.0, 89.9, 90.1, 89.95, 90.05, 90.0], [0.1] * 6)
    rec = combine(ws)["X:azimuth_deg"]
    assert np.all((rec.medians[1:] > 89.0) & (rec.medians[1:] < 91.0))


def test_a_parameter_with_a_zero_width_window_keeps_the_others():
    """A window whose interval has no width (a value held) is left out of
    that parameter's record; the others are combined."""
    from bayescal.record import combine
    ws = _azimuth_windows([30.0, 30.1, 29.9, 30.05], [0.1, 0.0, 0.1, 0.1])
    rec = combine(ws)["X:azimuth_deg"]
    assert len(rec.starts) == 3 and abs(rec.fit.mu["median"] - 30.0) < 0.2


def test_windows_whose_sampler_stopped_early_exit_3_and_are_named(files, tmp_path, capsys):
    """With --max-steps too small for the convergence rule, the record is
    written, each window's NOT CONVERGED line is printed, record.json lists
    the windows and the exit code is 3, as bayescal fit's."""
    from bayescal.cli import main
    out = tmp_path / "rec"
    code = main(["windows", "--ref", files["ref.mseed"], "--ref-xml", files["ref.xml"],
                 "--sut", files["sut.mseed"], "--sut-xml", files["sut.xml"], "--band", "0.1",
                 "0.8", "--window", str(WINDOW), "--out", str(out), "--quiet", "--no-report",
                 "--max-steps", "40"])
    doc = json.loads((out / "record.json").read_text())
    printed = capsys.readouterr().out
    assert code == 3
    assert len(doc["not_converged"]) == 3
    assert printed.count("NOT CONVERGED: the sampler of window") == 3


def test_span_keeps_two_sensors_with_the_same_seed_ids_apart():
    """A huddle test's two sensors written with the same SEED ids: the
    reference records [0, 1000) s, the SUT [100, 1100) s; the common span is
    [100, 1000) s (taking the ids together would give [0, 1100))."""
    from obspy import Stream, Trace, UTCDateTime

    from bayescal.record.windows import recorded_span
    t = UTCDateTime(2026, 1, 1)

    def stream(offset):
        return Stream([Trace(np.zeros(1000), header={
            "network": "XX", "station": "HUD", "location": "00", "channel": f"HH{c}",
            "sampling_rate": 1.0, "starttime": t + offset}) for c in "ZNE"])
    first, last = recorded_span(stream(0.0), stream(100.0))
    assert (first - t, last - t) == (100.0, 1000.0)


@pytest.mark.parametrize("medians, sds", [
    # drawn about 0.2 degrees (sd 0.3): their weighted circular mean falls just west of north
    ([359.96, 359.8, 0.13, 0.33, 0.54, 0.23], [0.05, 0.05, 0.4, 0.4, 0.4, 0.4]),
    # two precise windows either side of 0.2 and four imprecise ones west of north: the
    # record's value lies west of north, the precise windows' weighted mean east of it
    ([0.7, 359.9, 359.5, 359.5, 359.5, 359.5], [0.05, 0.05, 0.3, 0.3, 0.3, 0.3])])
def test_azimuths_near_north_are_reported_as_the_fit_reports_them(tmp_path, medians, sds):
    """As ``bayescal fit`` reports an azimuth: the record's value in
    [0, 360) with its intervals contiguous about it (an end may pass 0 or
    360); windows.csv's rows each with the window's own median (in
    [0, 360), as its fit gave it) and its intervals about it."""
    from bayescal.cli.windows import write_csv
    from bayescal.record import combine
    records = combine(_azimuth_windows(medians, sds))
    mu = records["X:azimuth_deg"].summary()["mu"]
    assert 0.0 <= mu["median"] < 360.0, mu
    for level in ("ci68", "ci95"):
        lo, hi = mu[level]
        assert lo <= mu["median"] <= hi and hi - lo < 180.0, mu
    write_csv(records, tmp_path / "windows.csv")
    rows = list(csv.DictReader((tmp_path / "windows.csv").open()))
    assert [float(r["median"]) for r in rows] == pytest.approx(medians, abs=1e-9)
    for r, m, s in zip(rows, medians, sds):
        assert float(r["ci95_low"]) == pytest.approx(m - 2 * s)
        assert float(r["record_ci95_low"]) <= m <= float(r["record_ci95_high"]), r


def test_budget_notes_are_said_with_the_table_as_bayescal_fit_says_them(files, tmp_path, capsys,
                                                                         monkeypatch):
    """Work budgets of 40 model evaluations, which no window's least squares
    or mode search finishes: each stage's note is printed once on stdout
    with the table, counted over the three windows (as ``bayescal fit``
    prints it with its summary), and not as a warning on stderr."""
    from bayescal.cli import main
    from bayescal.core import budget
    monkeypatch.setattr(budget, "LEAST_SQUARES_WORK", 40)
    monkeypatch.setattr(budget, "MODE_SEARCH_WORK", 40)
    main(["windows", "--ref", files["ref.mseed"], "--ref-xml", files["ref.xml"],
          "--sut", files["sut.mseed"], "--sut-xml", files["sut.xml"], "--band", "0.1", "0.8",
          "--window", str(WINDOW), "--out", str(tmp_path / "rec"), "--quiet", "--no-report",
          "--max-steps", "40"])
    said = capsys.readouterr()
    for stage in ("least squares", "mode search"):
        line = (f"budget spent: {stage}: ended by its work budget (40 model evaluations); "
                "a narrower --band helps (fewer bands to fit) (3 times)")
        assert said.out.splitlines().count(line) == 1, said.out
    assert "budget spent" not in said.err, said.err


def test_record_json_holds_the_settings_that_reproduce_the_run(pair, files, tmp_path):
    """record.json's settings: the band, seed, window length and likelihood
    as given, the span cut into windows (the pair's first sample to three
    windows later, ISO) and the windows fitted and skipped; a second run
    given those settings as --start, --end, --seed, --band and --window
    writes the same windows.csv."""
    from bayescal.cli import main
    t0 = pair.ref[0].stats.starttime
    base = ["windows", "--ref", files["ref.mseed"], "--ref-xml", files["ref.xml"],
            "--sut", files["sut.mseed"], "--sut-xml", files["sut.xml"], "--quiet", "--no-report"]
    main(base + ["--band", "0.1", "0.8", "--window", str(WINDOW), "--seed", "7",
                 "--out", str(tmp_path / "a")])
    s = json.loads((tmp_path / "a" / "record.json").read_text())["settings"]
    assert s["band_hz"] == [0.1, 0.8] and s["seed"] == 7 and s["window_s"] == WINDOW
    assert s["window_likelihood"] == "gaussian"
    assert (s["start"], s["end"]) == (t0.isoformat(), (t0 + 3 * WINDOW).isoformat())
    assert (s["windows_fitted"], s["windows_skipped"]) == (3, 0)
    main(base + ["--band", *map(str, s["band_hz"]), "--window", str(s["window_s"]),
                 "--seed", str(s["seed"]), "--start", s["start"], "--end", s["end"],
                 "--out", str(tmp_path / "b")])
    assert ((tmp_path / "b" / "windows.csv").read_text()
            == (tmp_path / "a" / "windows.csv").read_text())
