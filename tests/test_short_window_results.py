"""The short-window study's stored summary
(validation/results/repeatability/short_windows.json, written by
validation/studies/short_windows.py) against the table
docs/validation/hard_posteriors.md quotes, and the study's own checks
against their binomial and chi-square bands (102 windows: at least 90
whole-record values held at 95 %, repeatability ratio in [0.83, 1.17])."""
from __future__ import annotations

import json
from pathlib import Path

from scipy.stats import binom, chi2

ROOT = Path(__file__).resolve().parents[1]


def test_quoted_rows_are_the_stored_study_within_their_bands():
    s = json.loads((ROOT / "validation" / "results" / "repeatability" /
                    "short_windows.json").read_text())["summary"]["drop"]
    doc = " ".join((ROOT / "docs" / "validation" / "hard_posteriors.md").read_text().split())
    lo_held = int(binom.ppf(0.005, 102, 0.95))
    lo_r, hi_r = (float(chi2.ppf(q, 101) / 101) ** 0.5 for q in (0.005, 0.995))
    for ch, label in (("LHN", "north"), ("LHE", "east")):
        x = s[ch]
        assert x["windows"] == 102
        assert x["holds_whole_record"] >= lo_held, (ch, x["holds_whole_record"], lo_held)
        assert lo_r <= x["repeatability_ratio"] <= hi_r, (ch, x["repeatability_ratio"])
        row = (f"| {label} | {x['holds_whole_record']} / 102 | {x['repeatability_ratio']:.2f} | "
               f"{x['median_width95']:.2f} deg | {x['width_over_bound_median']:.2f} | "
               f"{x['scatter_over_bound']:.2f} | {x['narrower_than_bound']} "
               f"({x['width_over_bound_min']:.2f} and above) |")
        assert row in doc, row
