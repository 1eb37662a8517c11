"""The report's shortcuts that leave what it shows unchanged: corner plots
from at most :data:`~bayescal.report.corner_pages.CORNER_DRAWS` evenly
spaced draws, said on the page, and the misfit panel's expected range from
the Gamma quantiles in closed form."""
from __future__ import annotations

import math

import numpy as np
import pytest

from bayescal.report.corner_pages import CORNER_DRAWS, _draws_line, thinned
from bayescal.report.fit_pages import misfit_range


@pytest.mark.parametrize("n, stride", [(4999, 1), (5000, 1), (5001, 2), (10000, 2),
                                       (10001, 3), (40000, 8)])
def test_thinned_keeps_every_kth_draw_up_to_the_limit(n, stride):
    data = np.arange(2 * n, dtype=float).reshape(n, 2)
    kept = thinned(data)
    assert len(kept) == math.ceil(n / stride) <= CORNER_DRAWS
    np.testing.assert_array_equal(kept[:, 0], 2.0 * np.arange(0, n, stride))


def test_the_corner_note_says_how_many_draws_it_shows():
    assert _draws_line(CORNER_DRAWS) == ""
    assert "Drawn from 5000 of the 40000 posterior draws (one in 8)" in _draws_line(40000)


@pytest.mark.parametrize("n_r", [1, 2, 3])
def test_misfit_range_is_the_gamma_central_interval(n_r):
    # the mean of n_r unit exponentials is Gamma(n_r, 1/n_r): its CDF in closed form
    def cdf(x):
        y = n_r * x
        return 1 - math.exp(-y) * sum(y ** j / math.factorial(j) for j in range(n_r))

    lo, hi = misfit_range(n_r)
    assert cdf(lo) == pytest.approx(0.025, abs=1e-10)
    assert cdf(hi) == pytest.approx(0.975, abs=1e-10)
    if n_r == 1:
        assert (lo, hi) == pytest.approx((-math.log(0.975), -math.log(0.025)), rel=1e-12)
