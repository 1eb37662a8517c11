"""The reduced chi-square of window medians (validation/studies/repeatability.py)
on numbers with a known answer."""
import numpy as np
import pytest

from bayescal.core.checks.repeatability import reduced_chi_square, sd_from_ci68


def test_equal_sds_give_the_plain_sample_variance_ratio():
    # mean 2, squared deviations 1 + 0 + 1 = 2 over sd^2 = 0.25, over n - 1 = 2 -> 4
    chi2, ratio = reduced_chi_square([1.0, 2.0, 3.0], [0.5, 0.5, 0.5])
    assert chi2 == pytest.approx(4.0) and ratio == pytest.approx(2.0)


def test_unequal_sds_use_the_inverse_variance_mean():
    # weights 1 and 1/4: mean (0 + 5/4) / (5/4) = 1; (0-1)^2/1 + (5-1)^2/4 = 5, over 1
    chi2, _ = reduced_chi_square([0.0, 5.0], [1.0, 2.0])
    assert chi2 == pytest.approx(5.0)


def test_honest_intervals_average_one():
    rng = np.random.default_rng(3)
    sd = rng.uniform(0.5, 2.0, size=(4000, 6))
    m = 10.0 + sd * rng.standard_normal(sd.shape)
    chi2 = [reduced_chi_square(mi, si)[0] for mi, si in zip(m, sd)]
    # chi-square(5)/5 has mean 1 and sd sqrt(2/5); 4000 draws: standard error 0.01
    assert np.mean(chi2) == pytest.approx(1.0, abs=0.04)
    # intervals half the true scatter: chi2_red about 4
    chi2_narrow = [reduced_chi_square(mi, si / 2)[0] for mi, si in zip(m, sd)]
    assert np.mean(chi2_narrow) == pytest.approx(4.0, abs=0.16)


def test_sd_from_interval_and_bad_input():
    assert sd_from_ci68([[1.0, 3.0], [0.0, 1.0]]).tolist() == [1.0, 0.5]
    with pytest.raises(ValueError):
        reduced_chi_square([1.0], [1.0])
