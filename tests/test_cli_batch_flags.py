"""The batch report's flags compare results of one pair only, its time axis
writes each date once, its first page is a summary in sentences and tables,
and ``batch`` and ``report`` flag at one default threshold."""
from __future__ import annotations

import csv

import pytest

from bayescal.report import batch as rb

REF_A = "XX.A.00.BH1;XX.A.00.BH2"
REF_B = "XX.A.20.BH1;XX.A.20.BH2"


def _row(day, az, half, refs, label=None, channel="XX.A.10.BH1"):
    return {"label": label or f"{day}-{refs[5:7]}", "station": "XX.A", "day": day,
            "channel": channel, "reference_channels": refs, "kind": "horizontal",
            "azimuth": az, "azimuth_lo95": az - half, "azimuth_hi95": az + half,
            "nominal_azimuth": 0.0, "dip": None, "nominal_dip": 0.0, "gain": None,
            "gain_lo95": None, "gain_hi95": None, "nominal_gain": None, "ess_min": 900.0,
            "tau_max": 40.0, "rhat_max": 1.001, "converged": "True", "error": ""}


#: Two pairs of one station (the SUT's BH1 against two references) on two
#: days: 0 and 5 degrees off nominal, each pair steady to 0.1 degree.
ROWS = [_row("2026-01-01", 0.0, 0.2, REF_A), _row("2026-01-01", 5.0, 0.2, REF_B),
        _row("2026-01-02", 0.1, 0.2, REF_A), _row("2026-01-02", 5.1, 0.2, REF_B)]


def _flags(rows, thr=2.0):
    return {(f["reference_channels"], f["flag"], f["day"], f["previous_day"])
            for f in rb.find_flags(rows, thr, 2.0)}


def test_two_pairs_of_one_station_and_day_are_two_series():
    """Pair B is 5 deg off nominal on both days (beyond 2 deg and its
    +-0.2 interval); neither pair moved more than 0.1 deg, so nothing is
    'changed' although the two pairs differ by 5 deg on the same day."""
    assert _flags(ROWS) == {(REF_B, "off_nominal", "2026-01-01", ""),
                            (REF_B, "off_nominal", "2026-01-02", "")}
    # one pair moving by 3 deg (> 2 and > hypot(0.2, 0.2)) is a change of that pair only
    moved = ROWS[:3] + [_row("2026-01-02", 8.0, 0.2, REF_B)]
    changed = {f for f in _flags(moved) if f[1] == "changed"}
    assert changed == {(REF_B, "changed", "2026-01-02", "2026-01-01")}


def test_flags_csv_names_the_pair_and_the_results_compared(tmp_path):
    csv_path = tmp_path / "results.csv"
    moved = ROWS[:3] + [_row("2026-01-02", 8.0, 0.2, REF_B)]
    rb._write_csv(str(csv_path), rb.COLUMNS, moved)
    rb.write_report(str(csv_path), str(tmp_path))
    with open(tmp_path / "flags.csv") as fh:
        got = [f for f in csv.DictReader(fh) if f["flag"] == "changed"]
    assert len(got) == 1
    assert (got[0]["reference_channels"], got[0]["label"], got[0]["previous_label"]) == \
        (REF_B, "2026-01-02-20", "2026-01-01-20")
    assert float(got[0]["value"]) == pytest.approx(3.0)


def test_time_axis_writes_each_date_once():
    import matplotlib.pyplot as plt
    rows = [_row(d, 0.0, 0.2, r) for d in ("2026-01-01", "2026-01-02") for r in (REF_A, REF_B)]
    fig = rb._figure(rows, [], ["XX.A"], 2.0, 2.0, (8.27, 11.69))
    fig.canvas.draw()
    labels = [t.get_text() for t in fig.axes[0].get_xticklabels() if t.get_text()]
    plt.close(fig)
    assert labels == ["2026-01-01", "2026-01-02"]
    days = [f"2026-01-{d:02d}" for d in range(1, 32)]
    ticks = rb.date_ticks(days)
    assert len(ticks) == len(set(ticks)) <= 8 and str(ticks[0]) == "2026-01-01"


def test_summary_page_in_sentences_without_empty_lists():
    lines = rb.summary_lines(ROWS, rb.find_flags(ROWS), 2.0, 2.0)
    text = "\n".join(lines)
    assert "[]" not in text and "every item converged" in text
    assert text.startswith("4 items: 4 calibrated, 0 failed; 1 station, 2 days")
    late = [dict(r, converged="False") if r["label"] == "2026-01-02-20" else r for r in ROWS]
    assert "not converged: 2026-01-02-20" in "\n".join(
        rb.summary_lines(late, [], 2.0, 2.0))


def test_batch_and_report_flag_at_one_default():
    from bayescal.cli import build_parser
    parser = build_parser()
    report = parser.parse_args(["report", "somewhere"])
    batch = parser.parse_args(["batch", "--plan", "p.csv", "--out", "o"])
    assert report.threshold == batch.threshold == rb.FLAG_THRESHOLD_DEG
    assert batch.gain_threshold == rb.FLAG_THRESHOLD_PCT
