"""Calibrated uncertainty, checked statistically: over seeded simulated pairs
spanning coherence 0.9 to 0.999 (truths drawn at random: azimuths, dips,
gains), the angles' and gains' credible intervals hold the truth at their
nominal rates, for each kind of quantity on its own.

This is the small in-suite version of validation/studies/coverage_study.py (which runs
100 pairs with the full 15-parameter joint posterior; its table and plot are in
validation/results/coverage/)."""
import numpy as np

from bayescal.simulate.coverage import coverage_checks, run_case
from tests.tolerance import Z_001, interval_bounds, interval_power

#: Simulated pairs, seeds 500-547 (fixed before any result).
N_PAIRS = 48
KINDS = ("azimuth", "dip", "tilt", "gain")


def _pick(seed):
    """One check of each kind per pair, the channel turning with the seed, so
    that every kind's checks come from different pairs (independent)."""
    h, other = ("BH1", "BH2")[seed % 2], ("BH2", "BH1")[seed % 2]
    return {"azimuth": f"{h}:azimuth", "dip": f"{other}:dip",
            "tilt": ("BHZ:tilt_north", "BHZ:tilt_east")[seed % 2],
            "gain": f"{('BH1', 'BH2', 'BHZ')[seed % 3]}:gain"}


def test_intervals_cover_at_their_rates_for_each_kind():
    """Per kind, over 48 pairs: at least lo90 truths inside their 90 %
    intervals and at most hi68 inside their 68 % intervals
    (tests/tolerance.py, level 0.001 per kind), and the standardised errors
    (median - truth) / sd centred on 0 within 3.29 / sqrt(48) = 0.47.
    Catches one kind's intervals 1.5 times too narrow with power 0.44 and
    1.5 times too wide with power 0.35 (all four kinds 1.5 times too narrow:
    0.90), and a bias of 0.6 sd with power 0.8. A 10 % error in one kind's
    width needs the benchmark's thousands of checks."""
    rows = {k: [] for k in KINDS}
    for seed in range(500, 500 + N_PAIRS):
        post, azs, dips, resp, coh = run_case(seed, 1800.0, 10.0, (0.05, 1.0), "gain")
        assert post.summary()["convergence"]["converged"]
        c90 = coverage_checks(post, azs, dips, resp, level=90.0)
        c68 = coverage_checks(post, azs, dips, resp, level=68.0)
        for kind, name in _pick(seed).items():
            rows[kind].append((c90[name][0], c68[name][0], c90[name][1]))
    lo, hi = interval_bounds(N_PAIRS)
    assert (lo, hi) == (35, 42)
    assert 1 - (1 - interval_power(N_PAIRS, 1 / 1.5)) ** len(KINDS) > 0.9
    for kind, r in rows.items():
        in90, in68, z = (np.array(x) for x in zip(*r))
        assert lo <= in90.sum(), (kind, "too narrow", in90.sum(), lo)
        assert in68.sum() <= hi, (kind, "too wide", in68.sum(), hi)
        assert abs(z.mean()) < Z_001 / np.sqrt(z.size), (kind, "biased", z.mean())
