"""Calibrated uncertainty, checked statistically: over seeded simulated pairs
spanning coherence 0.9 to 0.999, 90 % credible intervals of angles and gains
must contain the truth at a rate consistent with 90 % (binomial tolerance).

This is the small in-suite version of benchmarks/coverage_study.py (which runs
100 pairs with the full 15-parameter joint posterior; its table and plot are in
reports/coverage/)."""
from bayescal.simulate.coverage import binomial_band, coverage_checks, run_case, summarise

N_PAIRS = 24


def test_ninety_percent_intervals_cover_ninety_percent():
    rows = []
    for seed in range(N_PAIRS):
        post, azs, dips, resp, coh = run_case(500 + seed, 1800.0, 10.0, (0.05, 1.0), "gain")
        assert post.summary()["convergence"]["converged"]
        rows.append({"coherence": coh, "checks": coverage_checks(post, azs, dips, resp)})
    table = summarise(rows)
    overall = table["all"]
    lo, hi = binomial_band(overall["n"], 0.9, alpha=0.01)
    assert lo <= overall["inside"] <= hi, table
    # standardised errors: unbiased and of unit spread
    assert abs(overall["z_mean"]) < 0.25 and 0.75 < overall["z_sd"] < 1.3, table
