"""Do the reported intervals match the data's own repeatability? The scatter
of one quantity's medians over time windows of a record, against the
intervals reported for each window (``validation/studies/repeatability.py``;
docs/validation/repeatability.md).

With window medians ``m_i`` and standard deviations ``sd_i`` (half the width
of each window's 68 % interval), the reduced chi-square

    chi2_red = sum_i (m_i - m_w)^2 / sd_i^2 / (n - 1),
    m_w = sum_i (m_i / sd_i^2) / sum_i (1 / sd_i^2)

is 1 on average when the quantity does not change between windows and the
intervals are honest (chi-square with n - 1 degrees of freedom over n - 1;
with equal ``sd_i`` the weighted mean ``m_w`` is the plain mean). Its square
root is the factor by which the intervals would have to grow to explain the
scatter.
"""
from __future__ import annotations

import numpy as np


def sd_from_ci68(ci68):
    """Half the width of 68 % intervals ``(n, 2)`` (or one ``[lo, hi]``)."""
    ci = np.asarray(ci68, float)
    return 0.5 * (ci[..., 1] - ci[..., 0])


def reduced_chi_square(medians, sds):
    """``(chi2_red, sqrt(chi2_red))`` of window medians against their
    standard deviations (see module notes); needs at least two windows."""
    m = np.asarray(medians, float)
    sd = np.asarray(sds, float)
    if m.size < 2 or m.shape != sd.shape:
        raise ValueError("reduced_chi_square needs two or more medians with one sd each")
    w = 1.0 / sd ** 2
    mean = np.sum(w * m) / np.sum(w)
    chi2 = float(np.sum(w * (m - mean) ** 2) / (m.size - 1))
    return chi2, float(np.sqrt(chi2))
