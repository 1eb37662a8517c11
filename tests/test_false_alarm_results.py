"""The false-alarm study's stored summaries (validation/results/diagnose/,
written by validation/studies/false_alarms.py) against what
docs/validation/diagnose.md quotes: the table rows as stored, each set
within its acceptance (at most 1 of 60 clean pairs with a name, extra
names on at most 5 % of the single-effect pairs), and the design rate
recomputed from Wilks's theorem (a chi-square with k degrees of freedom
beyond BIC_KEEP + k ln n)."""
from __future__ import annotations

import json
from pathlib import Path

import numpy as np
from scipy.stats import binom, chi2

ROOT = Path(__file__).resolve().parents[1]
STORED = ROOT / "validation" / "results" / "diagnose" / "false_alarms.json"


def _rows(table):
    out = {}
    for line in table.splitlines():
        cells = [c.strip() for c in line.strip("|").split("|")]
        if cells[0] in ("clean", "single effect"):
            out[cells[0]] = (line, [int(c) for c in cells[1:6]])
    return out


def test_quoted_table_is_the_stored_study_and_meets_its_acceptance():
    stored = json.loads(STORED.read_text())
    doc = (ROOT / "docs" / "validation" / "diagnose.md").read_text()
    rows = _rows(stored["table"])
    assert set(rows) == {"clean", "single effect"}
    for label, (line, (drawn, refused, _, named, _)) in rows.items():
        assert line in doc, line
        assert drawn == 60 and refused == 0, (label, drawn, refused)
        assert named <= (1 if label == "clean" else 3), (label, named)


def test_design_rate_is_wilks():
    """The stored per-pair design rate, recomputed: tilt k = 3 on n_tilt
    data, four one-parameter search candidates on n_search entries, and the
    binomial chance of more than 1 of 60 the docs quote."""
    d = json.loads(STORED.read_text())["design"]
    keep = d["bic_keep"]
    tilt = chi2.sf(keep + 3 * np.log(d["n_tilt"]), 3)
    one = chi2.sf(keep + np.log(d["n_search"]), 1)
    assert np.isclose(d["tilt"], tilt, rtol=1e-9) and np.allclose(d["search"], one, rtol=1e-9)
    pair = tilt + 4 * one
    assert np.isclose(d["pair"], pair, rtol=1e-9)
    doc = " ".join((ROOT / "docs" / "validation" / "diagnose.md").read_text().split())
    for quoted in (f"with probability {_sci(tilt)};", f"with {_sci(one)}.",
                   f"At most {_sci(pair)} a pair", f"with probability {_sci(binom.sf(1, 60, pair))} "
                   "(binomial)", f"n = 2 B n_u n_r = {d['n_search']} "):
        assert quoted in doc, quoted


def _sci(x):
    """``x`` as the docs write it: 3.5e-04."""
    return f"{x:.1e}"


def test_stored_details_follow_the_table_and_the_seed_design():
    """The per-pair facts diagnose.md quotes (``details``) against the
    stored table and the study's design: every single-effect pair counted
    once under its hidden effect, the named effects never more than those
    drawn, the hidden tilts not named are the tilt pairs less those named,
    and each clean pair with a name is one of the table's, its reference
    and noise shape those its seed fixes (reference by seed mod 3: 100x
    quieter, 10x quieter, as noisy; noise white in counts on even seeds)."""
    stored = json.loads(STORED.read_text())
    d, rows = stored["details"], _rows(stored["table"])
    _, (drawn, refused, _, named, _) = rows["single effect"]
    assert sum(v["of"] for v in d["named_by_effect"].values()) == drawn - refused
    assert all(0 <= v["named"] <= v["of"] for v in d["named_by_effect"].values())
    tilt = d["named_by_effect"]["tilt_noise"]
    assert len(d["missed_tilts"]) == tilt["of"] - tilt["named"]
    _, (_, _, _, clean_named, _) = rows["clean"]
    assert len(d["clean_named"]) == clean_named
    for pair in d["clean_named"]:
        assert 4000 <= pair["seed"] < 4060 and pair["named"]
        assert pair["regime"] == ("default", "ref10x", "equal")[pair["seed"] % 3]
        assert pair["noise"] == ("counts" if pair["seed"] % 2 == 0 else "ground")
