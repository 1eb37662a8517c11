"""The model-adequacy verdict of every fit (issue 13, item 1).

* the p-value of a misfit cell is the upper tail of Gamma(n_r, 1) at
  ``n_r * misfit`` (closed forms for n_r = 1 and 2), Bonferroni over cells;
* on the real ASL COWI pair the base model fails (``bayescal diagnose`` puts
  it at p = 5.6e-27): result.json, the first console line and page 1 of the
  report say so and point to ``bayescal diagnose``;
* on clean simulated pairs the check passes at its level: a seeded set of
  pairs, false-fail count within the binomial bound of the 1 % level, and
  the cell p-values centred as a uniform's.
"""
from __future__ import annotations

import io
import json
import sys
from contextlib import redirect_stdout
from pathlib import Path

import numpy as np
import pytest

from bayescal.core.adequacy import ALPHA, adequacy, band_p_values

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "examples"))


def test_p_values_closed_forms_and_bonferroni():
    v = np.array([[0.5, 3.0], [1.0, 12.0]])
    # n_r = 1: P(E >= v) = exp(-v); n_r = 2: P(Gamma(2,1) >= 2v) = (1 + 2v) exp(-2v)
    assert np.allclose(band_p_values(v, 1), np.exp(-v))
    assert np.allclose(band_p_values(v, 2), (1 + 2 * v) * np.exp(-2 * v))
    verdict = adequacy(v, [0.1, 0.2, 0.4], ["A", "B"], n_r=2)
    p_worst = (1 + 24.0) * np.exp(-24.0)
    assert verdict["ok"] is False
    assert verdict["worst"] == {"band_hz": [0.2, 0.4], "channel": "B", "misfit": 12.0,
                                "p": pytest.approx(p_worst)}
    assert [c["channel"] for c in verdict["failing"]] == ["B"]
    # 3.0 with n_r = 2: p = 7 e^-6 = 0.017 > 0.01 / 2 cells: passes Bonferroni
    ok = adequacy([[0.5], [3.0]], [0.1, 0.2, 0.4], ["A"], n_r=2)
    assert ok["ok"] is True and ok["worst"]["misfit"] == 3.0
    assert ok["worst"]["p"] == pytest.approx(7 * np.exp(-6))


def test_cowi_base_model_fails_and_says_so_first(cowi_data, tmp_path):
    from real_cowi import command

    from bayescal.cli import main
    from bayescal.report.fit import load_result
    from bayescal.report.fit_pages import page_summary
    from bayescal.report.layout import ReportContext

    out = tmp_path / "cowi"
    buf = io.StringIO()
    with redirect_stdout(buf):
        assert main(command(cowi_data, str(out))) == 0
    res = json.loads((out / "result.json").read_text())
    a = res["adequacy"]
    assert a["ok"] is False
    # gains held (--fit-response none): p = 5.6e-27 on LHE, upper band; with
    # the gains free (the default since issue 12 item 5) part of the misfit
    # is absorbed: p = 1.1e-9, misfit 11.9, on LHN in the upper band; with
    # the reference's noise estimated too (the default since) more of it:
    # p = 1.1e-5, misfit 7.1, on LHN in the upper band, measured
    assert a["worst"]["p"] < 1e-4
    assert a["worst"]["channel"] == "US.COWI..LHN"
    assert a["worst"]["band_hz"][1] == pytest.approx(1 / 3, rel=1e-6)
    assert a["worst"]["misfit"] > 5
    first = buf.getvalue().splitlines()[0]
    assert first.startswith("MODEL DOES NOT FIT THE DATA") and "bayescal diagnose" in first
    post = load_result(str(out))
    ctx = ReportContext(folder=str(out), post=post, summary=post.summary(), truth=None,
                        tolerance_deg=5.0)
    texts = [t.get_text() for t in page_summary(ctx).texts]
    assert texts[1].startswith("MODEL DOES NOT FIT THE DATA")    # under the title
    assert "bayescal diagnose" in texts[1].replace("\n", " ")
    assert "Flags" in texts[-1] and "none: every" not in texts[-1]


def test_clean_simulations_pass_at_the_level():
    from bayescal.io.pipeline import calibrate
    from bayescal.simulate.pair import simulate_pair

    n_pairs, fails, p_all = 6, 0, []
    for seed in range(n_pairs):
        rng = np.random.default_rng(100 + seed)
        sim = simulate_pair(duration=1800.0, fs=10.0, seed=100 + seed,
                            coherence=float(rng.uniform(0.9, 0.999)),
                            sut_azimuth=(float(rng.uniform(0, 360)), 0.0, 0.0))
        # the verdict is the misfit at the posterior median: a shorter chain
        # (as tests/test_diagnose.py uses) moves that median by a few per cent
        # of a standard deviation, which the level check does not depend on
        post = calibrate(sut=sim.sut, sut_xml=sim.sut_inventory, ref=sim.ref, ref_xml=sim.ref_inventory,
                         band=(0.02, 1.0), progress=False, min_ess=200, n_tau=20)
        verdict = post.summary()["adequacy"]
        fails += not verdict["ok"]
        d = post.diagnostics
        p_all.append(band_p_values(d["band_misfit"], len(d["ref_ids"])).ravel())
    # family-wise level 1 %: P(>= 2 false fails in 6) = 0.0015
    assert ALPHA == 0.01 and fails <= 1
    p = np.concatenate(p_all)
    # cell p-values centred like a uniform's: fraction below 1/2 within 3 sd
    half = np.mean(p < 0.5)
    assert abs(half - 0.5) < 3 * np.sqrt(0.25 / p.size), (half, p.size)
