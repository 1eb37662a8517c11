"""The report's shortcuts that leave what it shows unchanged: corner plots
from at most :data:`~bayescal.report.corner_pages.CORNER_DRAWS` evenly
spaced draws, said on the page, the misfit panel's expected range from
the Gamma quantiles in closed form, and Peterson's noise models read from
ObsPy's data file without importing ``obspy.signal``."""
from __future__ import annotations

import math
import subprocess
import sys

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


def test_noise_models_are_obspys():
    spectral = pytest.importorskip("obspy.signal.spectral_estimation")
    from bayescal.report.noise import peterson_models

    (pl, nl), (ph, nh) = peterson_models()
    for got, want in (((pl, nl), spectral.get_nlnm()), ((ph, nh), spectral.get_nhnm())):
        np.testing.assert_array_equal(got[0], want[0])
        np.testing.assert_array_equal(got[1], want[1])
    assert np.all(nl < nh)


def test_drawing_the_noise_models_imports_no_obspy_signal():
    code = ("import sys; import numpy as np; from types import SimpleNamespace; "
            "from matplotlib.figure import Figure; "
            "from bayescal.report.noise import draw_estimates; "
            "p = np.array([1.0, 10.0]); one = np.ones((1, 2)) * 1e-15; "
            "e = SimpleNamespace(period_s=p, psd=one, lo=one / 2, hi=one * 2, signal=one * 10, "
            "level=0.95); draw_estimates(Figure().add_subplot(), e, ['XX.A..BHZ']); "
            "print(sorted(m for m in sys.modules if m.startswith('obspy.signal')))")
    run = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True)
    assert run.returncode == 0, run.stderr
    assert run.stdout.strip().splitlines()[-1] == "[]"
