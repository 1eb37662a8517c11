"""The simulator's ``wave_seed``: one ground field at any record length."""
import numpy as np

from bayescal.simulate.pair import self_noise_psd, simulate_pair

FREQS = np.array([0.05, 0.2, 1.0])
KW = dict(fs=10.0, coherence=0.9, noise_in_counts=True)


def test_wave_seed_keeps_one_noise_level_at_two_lengths():
    """The simulator's spectra scale as 1 / the record's length (per-bin
    amplitudes independent of it); with ``wave_seed`` that is all that
    changes, so the self-noise of a 900-s and an 1800-s record differs by
    exactly 2. Without it the waves, and the noise level tied to their
    power, are other draws."""
    a, _ = self_noise_psd(FREQS, duration=900.0, seed=3, wave_seed=3, **KW)
    b, _ = self_noise_psd(FREQS, duration=1800.0, seed=3, wave_seed=3, **KW)
    np.testing.assert_allclose(a / b, 2.0, rtol=1e-3)
    a0, _ = self_noise_psd(FREQS, duration=900.0, seed=3, **KW)
    b0, _ = self_noise_psd(FREQS, duration=1800.0, seed=3, **KW)
    assert np.max(np.abs(a0 / b0 / 2.0 - 1.0)) > 0.05


def test_wave_seed_is_recorded_and_default_unchanged():
    sim = simulate_pair(duration=120.0, seed=5, wave_seed=5, **KW)
    assert sim.truth["wave_seed"] == 5
    plain = simulate_pair(duration=120.0, seed=5, **KW)
    again = simulate_pair(duration=120.0, seed=5, wave_seed=None, **KW)
    assert "wave_seed" not in plain.truth
    np.testing.assert_array_equal(plain.sut[0].data, again.sut[0].data)
    assert not np.array_equal(plain.sut[0].data, sim.sut[0].data)
