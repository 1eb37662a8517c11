"""The short-window study's stored summaries
(validation/results/repeatability/short_windows.json and, for the pooled
noise scale, short_windows_pooled.json, written by
validation/studies/short_windows.py) against the tables
docs/validation/hard_posteriors.md quotes, and the studies' own checks
against their binomial and chi-square bands (102 windows: at least 90
whole-record values held at 95 %, repeatability ratio in [0.83, 1.17])."""
from __future__ import annotations

import json
from pathlib import Path

from scipy.stats import binom, chi2

ROOT = Path(__file__).resolve().parents[1]
RESULTS = ROOT / "validation" / "results" / "repeatability"


def _quoted_and_within_bands(summary):
    """Each channel's row of ``summary`` quoted in the doc, its whole-record
    count and ratio inside their 99 % bands."""
    doc = " ".join((ROOT / "docs" / "validation" / "hard_posteriors.md").read_text().split())
    lo_held = int(binom.ppf(0.005, 102, 0.95))
    lo_r, hi_r = (float(chi2.ppf(q, 101) / 101) ** 0.5 for q in (0.005, 0.995))
    for ch, label in (("LHN", "north"), ("LHE", "east")):
        x = summary[ch]
        assert x["windows"] == 102
        assert x["holds_whole_record"] >= lo_held, (ch, x["holds_whole_record"], lo_held)
        assert lo_r <= x["repeatability_ratio"] <= hi_r, (ch, x["repeatability_ratio"])
        row = (f"| {label} | {x['holds_whole_record']} / 102 | {x['repeatability_ratio']:.2f} | "
               f"{x['median_width95']:.2f} deg | {x['width_over_bound_median']:.2f} | "
               f"{x['scatter_over_bound']:.2f} | {x['narrower_than_bound']} "
               f"({x['width_over_bound_min']:.2f} and above) |")
        assert row in doc, row


def test_quoted_rows_are_the_stored_study_within_their_bands():
    _quoted_and_within_bands(json.loads((RESULTS / "short_windows.json").read_text())["summary"]
                             ["drop"])


def test_pooled_scale_rows_are_the_stored_study_and_pass_every_check():
    """The pooled scale's run: quoted and within the bands as above, and its
    other two checks: median width over bound at most 1.1 times the scatter
    over bound, no window under its bound."""
    s = json.loads((RESULTS / "short_windows_pooled.json").read_text())
    assert s["own_scale_prob"] == 0.25 and s["scale_floor"] is True
    _quoted_and_within_bands(s["summary"]["drop"])
    for ch in ("LHN", "LHE"):
        x = s["summary"]["drop"][ch]
        assert x["narrower_than_bound"] == 0, x
        assert x["width_over_bound_median"] <= 1.1 * x["scatter_over_bound"], x
