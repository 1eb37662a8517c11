"""Poles-and-zeros evaluation (:mod:`bayescal.core.response.paz`) against
closed forms: a pendulum pair at its corner, a real pole's normalisation,
a digital first difference."""
import numpy as np
import pytest

from bayescal.core.response.paz import normalization_factor, transfer


def test_pendulum_at_its_corner_is_i_over_two_h():
    """H(s) = s^2 / (s^2 + 2 h w0 s + w0^2) at s = i w0 is exactly i / (2 h)
    (a quarter turn of phase, gain 1 / (2 h)); A0 scales it."""
    w0, h = 2 * np.pi / 120.0, 0.707
    poles = [-h * w0 + 1j * w0 * np.sqrt(1 - h * h), -h * w0 - 1j * w0 * np.sqrt(1 - h * h)]
    value = transfer(1j * w0, [0, 0], poles, a0=3.0)
    assert value == pytest.approx(3.0 * 1j / (2 * h), rel=1e-12)
    # vectorised: far above the corner the pair is flat (H -> 1), far below H ~ s^2 / w0^2
    s = 1j * np.array([1e4 * w0, 1e-4 * w0])
    assert transfer(s, [0, 0], poles) == pytest.approx([1.0, -1e-8], rel=1e-3)
    assert transfer(s.reshape(2, 1), [0, 0], poles).shape == (2, 1)


def test_normalization_factor_of_a_real_pole():
    """One pole at -a (rad/s), no zeros: |H(i w_n)| = 1 / sqrt(w_n^2 + a^2)."""
    a, fn = 7.0, 0.3
    wn = 2 * np.pi * fn
    assert normalization_factor([], [-a], fn) == pytest.approx(np.hypot(wn, a), rel=1e-14)
    assert abs(transfer(2j * np.pi * fn, [], [-a], normalization_factor([], [-a], fn))) \
        == pytest.approx(1.0, rel=1e-14)
    assert normalization_factor([], [], fn) == 1.0          # no roots: a flat stage
    assert np.array_equal(transfer(1j * np.arange(3.0), [], [], a0=2.0), np.full(3, 2.0 + 0j))


def test_digital_first_difference():
    """A zero at z = 1 in z = exp(i w dt): |H| = 2 sin(w dt / 2), phase (pi + w dt) / 2."""
    theta = np.linspace(0.1, 3.0, 7)
    h = transfer(np.exp(1j * theta), [1.0], [])
    assert np.abs(h) == pytest.approx(2 * np.sin(theta / 2), rel=1e-12)
    assert np.angle(h) == pytest.approx((np.pi + theta) / 2, rel=1e-12)


def test_one_set_of_roots_per_row():
    """Roots (W, n), one set per row (a posterior's draws): row w is the
    transfer of its own roots, each a closed form here. A real pole moved
    from -a to -b changes H by (s + a) / (s + b); a zero at -c gives s + c."""
    s = 2j * np.pi * np.array([0.1, 1.0, 10.0])
    a, b = np.array([3.0, 5.0]), np.array([4.0, 9.0])
    moved = transfer(s, -a[:, None], -b[:, None])
    assert moved.shape == (2, 3)
    np.testing.assert_allclose(moved, (s + a[:, None]) / (s + b[:, None]), rtol=1e-15)
    c = np.array([[2.0], [6.0]])
    both = transfer(s, -c, np.zeros((2, 0)))
    np.testing.assert_allclose(both, s[None] + c, rtol=1e-15)
