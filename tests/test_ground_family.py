"""The second family of ground spectra (bayescal.simulate.ground): its
expected cross-spectrum is the sum of its arrivals' (Rayleigh waves with
a vertical part in quadrature, Love waves transverse and horizontal) and
its isotropic background, under a steep fall below the corner; a drawn
field's power agrees with that expectation within its Gamma spread; the
pair simulator takes it by name."""
import numpy as np
import pytest
from scipy.stats import gamma

from bayescal.simulate import simulate_pair
from bayescal.simulate.ground import SteepMicroseism, ground_family

from tests.tolerance import LEVEL

FAMILY = SteepMicroseism()


def test_fall_below_the_corner_is_the_stated_power_law():
    f = np.array([FAMILY.corner_hz / 4, FAMILY.corner_hz / 2, FAMILY.corner_hz, 1.0])
    fall = FAMILY.fall(f)
    assert fall[2] == pytest.approx(0.5)
    assert fall[0] == pytest.approx(1 / (1 + 4.0 ** FAMILY.steepness))
    assert fall[3] == pytest.approx(1.0, abs=1e-6)


def test_expected_cross_spectrum_is_the_sum_of_its_arrivals():
    freqs = np.linspace(0.0, 2.0, 401)
    _, expected = FAMILY.draw(np.random.default_rng(0), freqs, wave_seed=5)
    arrivals = FAMILY.arrivals(np.random.default_rng([5, 98]))    # the draw's own generator
    assert {a[4] for a in arrivals} == {"love", "rayleigh"}          # both kinds in this draw
    want = np.zeros_like(expected)
    for k, phi, w, pol, kind in arrivals:
        radial = np.array([np.cos(phi), np.sin(phi), 0.0])
        if kind == "love":       # transverse, horizontal
            np.testing.assert_allclose(pol, [-np.sin(phi), np.cos(phi), 0.0], atol=1e-15)
        else:                    # radial, the vertical in quadrature
            np.testing.assert_allclose(pol.real, radial, atol=1e-15)
            assert pol[2].real == 0.0 and pol[2].imag != 0.0
        psd = w ** 2 * FAMILY.peak_psd(freqs, FAMILY.peaks[k]) * FAMILY.fall(freqs)
        want += psd[:, None, None] * np.outer(pol, pol.conj())[None]
    want += (FAMILY.background * FAMILY.fall(freqs) * (freqs > 0))[:, None, None] * np.eye(3)[None]
    np.testing.assert_allclose(expected, want, rtol=1e-12, atol=1e-15)


def test_drawn_field_power_agrees_with_its_expectation():
    """Each axis's power summed over M bins, over its expectation, is
    Gamma(M, 1/M) distributed (complex Gaussian bins)."""
    freqs = np.fft.rfftfreq(36000, 0.1)
    sel = (freqs > 0.03) & (freqs < 1.0)
    g, expected = FAMILY.draw(np.random.default_rng(11), freqs)
    m = int(sel.sum())
    for axis in range(3):
        ratio = np.sum(np.abs(g[axis, sel]) ** 2 / np.real(expected[sel, axis, axis])) / m
        lo, hi = gamma.ppf([LEVEL / 2, 1 - LEVEL / 2], m, scale=1.0 / m)
        assert lo < ratio < hi, (axis, ratio)


def test_pair_simulator_takes_the_family_by_name():
    kw = dict(duration=600.0, fs=5.0, seed=3)
    named = simulate_pair(ground="steep-microseism", **kw)
    assert named.truth["ground"] == "steep-microseism"
    assert np.array_equal(named.sut[0].data, simulate_pair(ground=FAMILY, **kw).sut[0].data)
    assert np.array_equal(simulate_pair(**kw).sut[0].data,
                          simulate_pair(ground="default", **kw).sut[0].data)
    assert ground_family(None) is None
    with pytest.raises(ValueError, match="unknown ground family"):
        ground_family("flat")
