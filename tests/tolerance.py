"""Tolerances of the statistical tests, derived rather than chosen: the
two-sided normal quantile at the suite's per-test level, the Monte Carlo
error of a posterior median, and binomial acceptance bands for coverage
counts with the power each band has against intervals that are too narrow
or too wide."""
from __future__ import annotations

from scipy.stats import binom, norm

#: Per-test false-failure level of every statistical test of the suite.
LEVEL = 0.001
#: Standard normal quantile of a two-sided check at LEVEL (3.29).
Z_001 = float(norm.isf(LEVEL / 2))


def median_mc_error(entry, ess):
    """Monte Carlo standard error of a posterior median (``entry`` a
    summary with ``sd``) from ``ess`` effective draws: sqrt(pi / 2) sd /
    sqrt(ESS), the asymptotic value for a Gaussian posterior."""
    return 1.2533 * entry["sd"] / ess ** 0.5


def coverage_band(n, level, alpha=LEVEL):
    """Counts (lo, hi) such that a count of truths inside ``level``
    intervals out of ``n`` independent checks falls below lo or above hi
    with probability at most ``alpha`` (``alpha / 2`` each side) when the
    intervals are right: accept lo <= k <= hi."""
    lo = int(binom.ppf(alpha / 2, n, level))
    if binom.cdf(lo, n, level) <= alpha / 2:     # ppf may land on the bound itself
        lo += 1
    hi = int(binom.isf(alpha / 2, n, level))
    if binom.sf(hi - 1, n, level) <= alpha / 2:
        hi -= 1
    return lo, hi


def scaled_coverage(level, factor):
    """Coverage of a nominal ``level`` central interval of a Gaussian
    posterior whose width is ``factor`` times the right one (factor < 1:
    too narrow)."""
    return float(2 * norm.cdf(factor * norm.isf((1 - level) / 2)) - 1)


def power(n, level, factor, alpha=LEVEL):
    """Probability that :func:`coverage_band` rejects ``n`` independent
    checks of ``level`` intervals that are ``factor`` times the right width."""
    lo, hi = coverage_band(n, level, alpha)
    p = scaled_coverage(level, factor)
    return float(binom.cdf(lo - 1, n, p) + binom.sf(hi, n, p))


#: Interval levels of the two one-sided coverage checks: too narrow shows
#: best as too few truths inside the 90 % intervals, too wide as too many
#: inside the 68 % intervals (the 90 % count saturates at n).
NARROW_LEVEL, WIDE_LEVEL = 0.9, 0.68


def interval_bounds(n, alpha=LEVEL):
    """(lo90, hi68) for ``n`` independent checks: intervals are called too
    narrow when fewer than lo90 truths lie inside their 90 % intervals,
    too wide when more than hi68 lie inside their 68 % intervals; each
    side has false-failure probability at most ``alpha / 2``."""
    lo = coverage_band(n, NARROW_LEVEL, alpha)[0]
    hi = coverage_band(n, WIDE_LEVEL, alpha)[1]
    return lo, hi


def interval_power(n, factor, alpha=LEVEL):
    """Probability that :func:`interval_bounds` calls ``n`` checks of
    Gaussian intervals ``factor`` times the right width wrong (factor < 1:
    too narrow, judged by the 90 % count; > 1: too wide, by the 68 %)."""
    lo, hi = interval_bounds(n, alpha)
    if factor < 1:
        return float(binom.cdf(lo - 1, n, scaled_coverage(NARROW_LEVEL, factor)))
    return float(binom.sf(hi, n, scaled_coverage(WIDE_LEVEL, factor)))
