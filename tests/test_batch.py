"""Batch calibration of a simulated network (3 stations x 3 days, 1 h a day
at 10 Hz): every item done once, the rotated station flagged on the day it
turned and no other, a killed run resumed without redoing or losing items,
the same numbers with 1 and 2 workers, bad pairs recorded without stopping
the others."""
import csv
import json
import os
import signal
import subprocess
import sys
import time

import numpy as np
import pytest
from scipy.stats import norm

from bayescal.network.batch import item_seed, read_log, run_batch
from bayescal.report.batch import read_results
from bayescal.cli import main
from bayescal.simulate.network import sds_path, write_network
from bayescal.network.plan import default_options, read_csv_plan, sds_plan
from tests.tolerance import LEVEL

SEED = 7
THRESHOLD = 2.0
BAND = (0.05, 1.0)   # fixed band: faster than choosing it per pair


def plan(net):
    return sds_plan(net["archive"], net["inventory"], defaults=default_options(band=BAND))


@pytest.fixture(scope="module")
def net(tmp_path_factory):
    return write_network(tmp_path_factory.mktemp("net"), n_stations=3, n_days=3, seed=3,
                         rotated_station="ST02", rotation_deg=5.0)


@pytest.fixture(scope="module")
def killed_then_resumed(net, tmp_path_factory):
    """Run the CLI in a subprocess, SIGKILL it (and its workers) once two
    items are finished, then resume in this process with 2 workers."""
    out = str(tmp_path_factory.mktemp("run"))
    cmd = [sys.executable, "-m", "bayescal.cli", "batch", "--plan", f"sds:{net['archive']}",
           "--inventory", net["inventory"], "--out", out, "--workers", "1", "--seed", str(SEED),
           "--band", *map(str, BAND), "--quiet"]
    proc = subprocess.Popen(cmd, start_new_session=True, stdout=subprocess.DEVNULL,
                            stderr=subprocess.DEVNULL)
    labels = [it["label"] for it in plan(net)]
    deadline = time.time() + 150
    try:
        while time.time() < deadline:
            done = [lb for lb in labels if os.path.exists(os.path.join(out, lb, "result.json"))]
            if len(done) >= 2:
                break
            assert proc.poll() is None, "batch subprocess ended before it could be killed"
            time.sleep(0.1)
    finally:
        os.killpg(proc.pid, signal.SIGKILL)   # the subprocess and its Dask workers
        proc.wait()
        time.sleep(0.5)   # let the worker processes of the group die too
    before = {lb: os.path.getmtime(os.path.join(out, lb, "result.json")) for lb in labels
              if os.path.exists(os.path.join(out, lb, "result.json"))}
    # the kill left no half-written item folder in place (only under .tmp/)
    placed = [lb for lb in labels if os.path.isdir(os.path.join(out, lb))]
    assert set(placed) == set(before), (placed, before)
    log_before = read_log(out)
    summary = run_batch(plan(net), out, seed=SEED, workers=2,
                        processes=False, quiet=True, threshold_deg=THRESHOLD)
    return {"out": out, "labels": labels, "before": before, "log_before": log_before,
            "summary": summary}


def test_killed_run_resumes_without_redoing_or_losing(killed_then_resumed):
    r = killed_then_resumed
    assert 2 <= len(r["before"]) < len(r["labels"])
    for lb, mtime in r["before"].items():   # finished before the kill: untouched
        assert os.path.getmtime(os.path.join(r["out"], lb, "result.json")) == mtime
    assert r["summary"]["skipped"] == len(r["before"])
    assert r["summary"]["computed"] == len(r["labels"]) - len(r["before"])
    assert r["summary"]["failed"] == 0
    # every item done exactly once over both runs, none lost, nothing half-written left
    log = read_log(r["out"])
    done = [e["label"] for e in log if e["event"] == "done"]
    assert sorted(done) == sorted(set(done))
    assert set(done) | set(r["before"]) == set(r["labels"])
    assert set(done[len([e for e in r["log_before"] if e["event"] == "done"]):]).isdisjoint(
        r["before"])
    for lb in r["labels"]:     # each item's result names its item
        with open(os.path.join(r["out"], lb, "result.json")) as fh:
            assert json.load(fh)["meta"]["batch_label"] == lb
    assert not os.path.exists(os.path.join(r["out"], ".tmp"))


def test_results_match_truth_and_rotated_station_flagged(killed_then_resumed, net):
    out = killed_then_resumed["out"]
    rows = read_results(os.path.join(out, "results.csv"))
    assert len(rows) == 9 * 3 and all(r["error"] == "" for r in rows)
    with open(net["truth"]) as fh:
        truth = json.load(fh)
    # every azimuth and dip against its truth, in sds read from the CSV's 95 %
    # interval (sd = width / 3.92, Gaussian): at most 54 checks share the
    # suite's level 0.001 (Bonferroni, |z| < 4.28), the medians' Monte Carlo
    # error at ESS >= 1000 (checked below: 1.25 sd / sqrt(1000)) added
    z = float(norm.isf(LEVEL / (2 * 2 * len(rows))))
    w = 2 * norm.isf(0.025) / np.hypot(1.0, 1.2533 / np.sqrt(1000))
    for r in rows:
        true = truth["stations"][r["station"].split(".")[1]]["days"][r["day"]][r["channel"]]
        if r["azimuth"] is not None:
            err = (r["azimuth"] - true["azimuth_deg"] + 180) % 360 - 180
            sd = (r["azimuth_hi95"] - r["azimuth_lo95"]) / w
            assert abs(err) < z * sd, (r["label"], r["channel"], err, sd)
            assert r["azimuth_lo95"] < r["azimuth"] < r["azimuth_hi95"]
        if r["dip_lo95"] is not None:
            sd = (r["dip_hi95"] - r["dip_lo95"]) / w
            assert abs(r["dip"] - true["dip_deg"]) < z * sd, (r["label"], r["channel"], r["dip"], sd)
        assert r["ess_min"] >= 1000 and r["rhat_max"] < 1.01
        # 1 h at 0.05 Hz: 180 periods, no short-record note (the simulated network's
        # self-noise follows the ground's spectrum, which a pair cannot tell from a
        # gain: the separation note may be there)
        assert "short record" not in r["notes"], r["notes"]
        assert set(filter(None, r["notes"].split(";"))) <= {"reference noise poorly separated"}
    flags = killed_then_resumed["summary"]["flag_list"]
    assert {f["station"] for f in flags} == {"XX.ST02"}
    changed = [f for f in flags if f["flag"] == "changed"]
    assert {(f["channel"].split(".")[-1], f["quantity"], f["day"]) for f in changed} == \
        {("BH1", "azimuth", "2026-01-02"), ("BH2", "azimuth", "2026-01-02")}
    for f in changed:
        assert abs(f["value"] - 5.0) < 0.6
    off = {(f["channel"].split(".")[-1], f["day"]) for f in flags if f["flag"] == "off_nominal"}
    assert off == {(c, d) for c in ("BH1", "BH2") for d in ("2026-01-02", "2026-01-03")}
    with open(os.path.join(out, "flags.csv")) as fh:
        assert len(list(csv.DictReader(fh))) == len(flags)
    for name in ("report.pdf", "report.png"):
        assert os.path.getsize(os.path.join(out, name)) > 10_000
    for lb in killed_then_resumed["labels"]:   # the usual result folder of `bayescal fit`
        for name in ("result.json", "samples.npz", "sut_corrected.xml", "item.json"):
            assert os.path.exists(os.path.join(out, lb, name)), (lb, name)


#: results.csv's interval columns and the result.json entries they report.
_CSV_COLUMNS = {"azimuth": ("azimuth_deg",), "dip": ("dip_deg",), "tilt": ("tilt_deg",),
                "gain": ("response", "gain")}


def _samples_table(out, rows):
    """``{(station, channel): [(day, quantity, median, lo95, hi95, nominal,
    bound)]}``
    recomputed from each item's samples.npz (tests/intervals.py): 2.5/50/
    97.5 % percentiles, a near-vertical channel's tilt and dip over its 95 %
    lean region; nominal values from the item's result.json (its StationXML)."""
    from tests.intervals import FLOAT, fit_samples, region_interval, tails
    table, seen = {}, {}
    for r in rows:
        if r["label"] not in seen:
            seen[r["label"]] = fit_samples(os.path.join(out, r["label"]))
        res, samples = seen[r["label"]]
        cid = r["channel"]
        nominal = res["channels"][cid].get("nominal", {})
        for col, path in _CSV_COLUMNS.items():
            x = samples.get((cid, path))
            if x is None:
                continue
            if isinstance(x, tuple):
                (lo, hi), tol = region_interval(x[1], "ci95", dip=path == ("dip_deg",))
                med = np.median(x[2])
            else:
                med, (lo, hi), tol = np.median(x), np.percentile(x, tails("ci95")), FLOAT
            nom = nominal.get({"gain": "gain"}.get(col, f"{col}_deg"))
            table.setdefault((r["station"], cid), []).append(
                (r["day"], col, med, lo, hi, nom, tol))
    return table


def _wrap(d):
    return (d + 180.0) % 360.0 - 180.0


def _flags_by_the_stated_rule(table, threshold_deg, threshold_pct=2.0):
    """flags.csv by the rule report/batch.py states, from ``table``:
    off_nominal when |deviation| > threshold and the 95 % interval of the
    deviation excludes 0; changed (on the later day) when the move between
    consecutive days exceeds the threshold and sqrt(h1^2 + h2^2), h the 95 %
    half-widths. Deviations in degrees (azimuth wrapped), gains in percent
    of nominal. Each flag's numbers come with the bound they carry from
    ``table``."""
    flags = {}
    for (sta, cid), entries in table.items():
        for quantity, thr in (("azimuth", threshold_deg), ("dip", threshold_deg),
                              ("gain", threshold_pct)):
            series = []
            for day, q, med, lo, hi, nom, tol in sorted(entries):
                if q != quantity or nom is None:
                    continue
                if q == "gain":
                    dev, dlo, dhi = (100.0 * (v / nom - 1.0) for v in (med, lo, hi))
                else:
                    dev = _wrap(med - nom) if q == "azimuth" else med - nom
                    dlo, dhi = dev - (med - lo), dev + (hi - med)
                series.append((day, dev, dlo, dhi, tol))
                if abs(dev) > thr and not dlo <= 0.0 <= dhi:
                    flags[cid, quantity, "off_nominal", day] = (dev, dlo, dhi, nom, tol)
            for (d0, v0, lo0, hi0, t0), (d1, v1, lo1, hi1, t1) in zip(series, series[1:]):
                delta = _wrap(v1 - v0) if quantity == "azimuth" else v1 - v0
                h = np.hypot((hi0 - lo0) / 2, (hi1 - lo1) / 2)
                if abs(delta) > thr and abs(delta) > h:
                    flags[cid, quantity, "changed", d1] = (delta, delta - h, delta + h, v0,
                                                           t0 + t1)
    return flags


def test_results_and_flags_csv_intervals_are_those_of_the_samples(killed_then_resumed):
    """Every median and 95 % bound of results.csv (azimuth, dip, tilt, gain)
    is the 2.5/50/97.5 % percentile of that item's samples.npz (tilt and a
    vertical's dip: the range over the 95 % lean region), and flags.csv
    holds the flags (and their values and 95 % bounds) that the stated rule
    gives from those samples. Bound: float rounding (1e-9; the CSVs keep
    every digit); a tilt region's range: tests/intervals.region_tolerance
    (its boundary walked at other points), carried into the flags' bounds."""
    from tests.intervals import FLOAT
    out = killed_then_resumed["out"]
    with open(os.path.join(out, "results.csv")) as fh:
        rows = list(csv.DictReader(fh))
    table = _samples_table(out, rows)
    by_row = {(r["station"], r["channel"], r["day"]): r for r in rows}
    for (sta, cid), entries in table.items():
        for day, col, med, lo, hi, _, tol in entries:
            r = by_row[sta, cid, day]
            got = [float(r[col]), float(r[f"{col}_lo95"]), float(r[f"{col}_hi95"])]
            np.testing.assert_allclose(got, [med, lo, hi], rtol=FLOAT, atol=tol,
                                       err_msg=f"{r['label']} {cid} {col}")
    # 9 items x (2 horizontals x azimuth, dip, gain + vertical tilt, dip, gain)
    assert sum(len(v) for v in table.values()) == 9 * 9
    with open(os.path.join(out, "flags.csv")) as fh:
        written = {(f["channel"], f["quantity"], f["flag"], f["day"]):
                   [float(f[k]) for k in ("value", "lo95", "hi95", "reference")]
                   for f in csv.DictReader(fh)}
    want = _flags_by_the_stated_rule(table, THRESHOLD)
    assert set(written) == set(want) and want, (sorted(written), sorted(want))
    for key, numbers in written.items():
        np.testing.assert_allclose(numbers, want[key][:4], rtol=FLOAT, atol=want[key][4],
                                   err_msg=str(key))


def test_corrected_stationxml_of_every_item_holds_its_fit_and_the_truth(killed_then_resumed,
                                                                       net):
    """Each item's sut_corrected.xml carries that item's posterior medians
    (azimuth, dip, stage gain and the sensitivity it implies), and those lie
    within 3.29 posterior sd of the simulation's truth (two-sided level
    0.001 each); on the station turned by 5 degrees the corrected azimuths
    exclude the unchanged metadata's by more than 3.29 sd."""
    from obspy import read_inventory

    from tests.tolerance import Z_001

    out = killed_then_resumed["out"]
    with open(net["truth"]) as fh:
        truth = json.load(fh)
    turned = 0
    for lb in killed_then_resumed["labels"]:
        with open(os.path.join(out, lb, "result.json")) as fh:
            res = json.load(fh)
        inv = read_inventory(os.path.join(out, lb, "sut_corrected.xml"))
        day = res["meta"]["starttime"][:10]
        for cid, e in res["channels"].items():
            sta, cha = cid.split(".")[1], cid.split(".")[3]
            true = truth["stations"][sta]["days"][day][cid]
            ch = inv.select(station=sta, location="10", channel=cha)[0][0][0]
            dip = e["dip_deg"]
            assert ch.dip == pytest.approx(dip["median"], abs=1e-9), (lb, cid)
            assert abs(ch.dip - true["dip_deg"]) < Z_001 * dip["sd"], (lb, cid, ch.dip)
            if abs(true["dip_deg"]) < 80:
                az = e["azimuth_deg"]
                assert ch.azimuth == pytest.approx(az["median"] % 360, abs=1e-9), (lb, cid)
                err = (ch.azimuth - true["azimuth_deg"] + 180) % 360 - 180
                assert abs(err) < Z_001 * az["sd"], (lb, cid, err, az["sd"])
                nominal = e["nominal"]["azimuth_deg"]
                if abs((true["azimuth_deg"] - nominal + 180) % 360 - 180) > 4.0:   # turned
                    turned += 1
                    off = (ch.azimuth - nominal + 180) % 360 - 180
                    assert abs(off) > Z_001 * az["sd"], (lb, cid, off)
            g = e["response"]["gain"]
            stage = ch.response.response_stages[0]
            assert stage.stage_gain == pytest.approx(g["median"], rel=1e-9), (lb, cid)
            assert abs(stage.stage_gain - true["gain"]) < Z_001 * g["sd"], (lb, cid, g)
            # flat digitizer, pendulum normalised at 1 Hz: sensitivity = gain x 4e5
            assert ch.response.instrument_sensitivity.value == pytest.approx(
                g["median"] * 4.0e5, rel=1e-6), (lb, cid)
    assert turned == 4          # BH1 and BH2 of ST02 on its two turned days


def test_same_seed_same_numbers_with_one_or_two_workers(killed_then_resumed, net, tmp_path):
    r = killed_then_resumed
    redo = [lb for lb in r["labels"] if lb not in r["before"]][:2]   # made with 2 workers
    items = [it for it in plan(net) if it["label"] in redo]
    from distributed import LocalCluster
    with LocalCluster(n_workers=1, threads_per_worker=1, processes=False,
                      dashboard_address=None) as cluster:   # an existing scheduler
        run_batch(items, str(tmp_path), seed=SEED, scheduler=cluster.scheduler_address,
                  quiet=True, report=False)
    for lb in redo:
        a = np.load(os.path.join(r["out"], lb, "samples.npz"))["samples"]
        b = np.load(os.path.join(tmp_path, lb, "samples.npz"))["samples"]
        np.testing.assert_array_equal(a, b)
        with open(os.path.join(tmp_path, lb, "item.json")) as fh:
            assert json.load(fh)["seed"] == item_seed(SEED, lb)
    assert item_seed(SEED, redo[0]) != item_seed(SEED + 1, redo[0]) != item_seed(SEED, redo[1])


def test_csv_plan_bad_pairs_recorded_others_done(net, tmp_path, capsys):
    day = net["days"][0]
    files = {loc: ";".join(sds_path(net["archive"], "XX", "ST01", loc, c, day)
                           for c in (("BH1", "BH2", "BHZ") if loc == "10" else
                                     ("BHN", "BHE", "BHZ")))
             for loc in ("10", "00")}
    xml = os.path.join(net["inventory"], "XX.ST01.xml")
    table = tmp_path / "plan.csv"
    table.write_text(
        "label,ref,ref_xml,sut,sut_xml,band_min,band_max,start,end\n"
        f"good,{files['00']},{xml},{files['10']},{xml},0.04,0.9,,\n"
        f"missing,{files['00']},{xml},/nonexistent/sut.mseed,{xml},,,,\n"
        f"no_overlap,{files['00']},{xml},{files['10']},{xml},,,"
        f"{day}T05:00:00,{day}T06:00:00\n")
    out = tmp_path / "out"
    code = main(["batch", "--plan", str(table), "--out", str(out), "--workers", "1", "--quiet",
                 "--seed", "1", "--band", *map(str, BAND)])
    assert code == 1   # some items failed
    assert "1 calibrated" in capsys.readouterr().out
    rows = {r["label"]: r for r in read_results(out / "results.csv")
            if not r["channel"].endswith("BHZ")}
    assert "/nonexistent/sut.mseed" in rows["missing"]["error"]
    assert "file not found" in rows["missing"]["error"]
    assert "lies outside the common time" in rows["no_overlap"]["error"]   # item 4 wording
    assert rows["good"]["error"] == "" and rows["good"]["azimuth"] is not None
    assert json.loads((out / "missing" / "error.json").read_text())["label"] == "missing"
    good = json.loads((out / "good" / "result.json").read_text())
    assert good["meta"]["band_hz"][0] >= 0.04 and good["meta"]["band_hz"][1] <= 0.9 + 1e-9
    # a rerun retries the failed items only
    assert main(["batch", "--plan", str(table), "--out", str(out), "--quiet",
                 "--band", *map(str, BAND)]) == 1
    log = read_log(out)
    assert [e["label"] for e in log if e["event"] == "skipped"] == ["good"]
    assert sorted(e["label"] for e in log if e["event"] == "failed") == \
        ["missing", "missing", "no_overlap", "no_overlap"]


def test_bad_plans_name_the_file(net, tmp_path, capsys):
    bad = tmp_path / "bad.csv"
    bad.write_text("label,sut\nx,a.mseed\n")
    out = tmp_path / "out"
    assert main(["batch", "--plan", str(bad), "--out", str(out)]) == 2
    assert f"{bad}: plan needs the columns" in capsys.readouterr().err
    assert main(["batch", "--plan", f"sds:{tmp_path}", "--inventory", net["inventory"],
                 "--out", str(out)]) == 2
    assert "no SDS files" in capsys.readouterr().err
    assert not out.exists()
    with pytest.raises(Exception):
        read_csv_plan(str(tmp_path / "absent.csv"))


def _row(day, az, half, gain=None, gain_half=0.0, channel="XX.A.10.BH1"):
    return {"label": f"XX.A.{day}", "station": "XX.A", "day": day, "channel": channel,
            "azimuth": az, "azimuth_lo95": az - half, "azimuth_hi95": az + half,
            "nominal_azimuth": 0.0, "dip": None, "nominal_dip": 0.0, "gain": gain,
            "gain_lo95": None if gain is None else gain - gain_half,
            "gain_hi95": None if gain is None else gain + gain_half,
            "nominal_gain": None if gain is None else 750.0, "error": ""}


def test_flag_rule_needs_threshold_and_uncertainty():
    from bayescal.report.batch import find_flags

    def flags(rows):
        return {(f["quantity"], f["flag"], f["day"]) for f in find_flags(rows, 2.0, 2.0)}

    # across north: 359.5 -> 0.7 is a 1.2 degree change, not 358.8
    assert flags([_row("2026-01-01", 359.5, 0.1), _row("2026-01-02", 0.7, 0.1)]) == set()
    # 3 degrees, tight intervals: changed and off nominal
    assert flags([_row("2026-01-01", 0.0, 0.1), _row("2026-01-02", 3.0, 0.1)]) == \
        {("azimuth", "changed", "2026-01-02"), ("azimuth", "off_nominal", "2026-01-02")}
    # 3 degrees but 95 % half-widths of 2.5 each (combined 3.5): the change is within the
    # uncertainty; the second day is still off nominal (its interval [0.5, 5.5] excludes 0)
    assert flags([_row("2026-01-01", 0.0, 2.5), _row("2026-01-02", 3.0, 2.5)]) == \
        {("azimuth", "off_nominal", "2026-01-02")}
    assert flags([_row("2026-01-01", 0.0, 3.5), _row("2026-01-02", 3.0, 3.5)]) == set()
    # gain 3 % above nominal, +-0.5 %: off nominal; +-4 %: not
    assert flags([_row("2026-01-01", 0.0, 0.1, gain=772.5, gain_half=3.75)]) == \
        {("gain", "off_nominal", "2026-01-01")}
    assert flags([_row("2026-01-01", 0.0, 0.1, gain=772.5, gain_half=30.0)]) == set()
