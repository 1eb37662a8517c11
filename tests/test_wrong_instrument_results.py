"""The wrong-instrument study's stored results (validation/results/diagnose/,
written by validation/studies/wrong_instrument.py) against what
docs/validation/diagnose.md quotes: each table row recounted from the
per-pair records, and the three kinds that pass held to their binomial
floor (95 % nominal coverage, failing with probability at most 0.05)."""
from __future__ import annotations

import json
from pathlib import Path

from scipy.stats import binom

ROOT = Path(__file__).resolve().parents[1]
RESULTS = ROOT / "validation" / "results" / "diagnose"
LABELS = {"period": "period 2-4x off", "damping": "damping 30 % off", "flat": "flat metadata"}


def _floor(n, p=0.95, alpha=0.05):
    return int(binom.ppf(alpha, n, p)) + (binom.cdf(binom.ppf(alpha, n, p), n, p) < alpha)


def _recount(rows, kind):
    rs = [r for r in rows if r["kind"] == kind]
    held = {}
    for r in rs:
        for key, ok in r["holds"].items():
            held.setdefault(key.split(":")[0], []).append(ok)
    return len(rs), sum(r["response_named"] for r in rs), {
        q: (sum(v), len(v)) for q, v in held.items()}


def test_quoted_table_is_the_stored_study_and_meets_its_floor():
    rows = json.loads((RESULTS / "wrong_instrument.json").read_text())["pairs"]
    doc = (ROOT / "docs" / "validation" / "diagnose.md").read_text()
    for kind, label in LABELS.items():
        n, named, held = _recount(rows, kind)
        assert n == 30 and named >= _floor(n)
        dp, of = held["damping_over_period"]
        assert of == 3 * n and dp >= _floor(of)
        row = f"| {label} | {n} | {named} (the SUT's corner) | {dp} of {of} |"
        assert row in doc, row
        if "period_s" in held:
            k, m = held["period_s"]
            assert k >= _floor(m) and f"{row} {k} of {m} |" in doc


def test_quoted_extra_pole_or_zero_row_is_the_stored_study_and_meets_its_floor():
    rows = json.loads((RESULTS / "wrong_instrument_pz.json").read_text())["pairs"]
    n, named, held = _recount(rows, "extra_pz")
    k, m = held["corner_hz"]
    assert n == 30 and named >= _floor(n) and m == named and k >= _floor(m)
    assert f"| extra pole or zero | {n} | {named} | - | {k} of {m} (corner " \
           "frequency) |" in (ROOT / "docs" / "validation" / "diagnose.md").read_text()
