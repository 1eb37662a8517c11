"""Cross-spectra: convention against scipy, gaps, chunking, band layout."""
import numpy as np
import pytest
from scipy.signal import csd

from bayescal.core.spectra.welch import SpectraError, cross_spectra

FS = 10.0


def _data(n=40_000, seed=0):
    rng = np.random.default_rng(seed)
    g = rng.standard_normal(n)
    return np.vstack([g + 0.3 * rng.standard_normal(n), np.roll(g, 3)]), rng.standard_normal((1, n)) + g


def test_convention_matches_scipy_csd():
    sut, ref = _data()
    sp = cross_spectra(sut, ref, FS, None, None, (0.05, 2.0), nperseg=1024)
    f, p = csd(sut[1], sut[0], fs=FS, window="hann", nperseg=1024, noverlap=512,
               detrend="linear", scaling="density")
    keep = (f >= 0.05) & (f <= 2.0)
    ours = sp.total[:, 0, 1] * sp.psd_scale / sp.n_segments    # C[0,1] = Z_0 conj(Z_1)
    assert np.allclose(ours, p[keep], rtol=1e-10)


def test_gap_drops_segments_and_chunking_changes_nothing():
    sut, ref = _data()
    sut[0, 10_000:10_050] = np.nan
    a = cross_spectra(sut, ref, FS, None, None, (0.05, 2.0), nperseg=1024, chunk=5)
    b = cross_spectra(sut, ref, FS, None, None, (0.05, 2.0), nperseg=1024, chunk=64)
    # samples 10000-10049 lie in the segments starting at 9216 and 9728 only
    assert a.n_segments_possible - a.n_segments == 2
    assert np.allclose(a.total, b.total) and np.allclose(a.per_segment, b.per_segment)


def test_bands_cover_the_band_with_enough_bins():
    sut, ref = _data()
    sp = cross_spectra(sut, ref, FS, None, None, (0.02, 2.0), nperseg=2048)
    assert sp.band_edges[0] == pytest.approx(0.02) and sp.band_edges[-1] == pytest.approx(2.0)
    assert sp.bins_per_band.min() >= 8 and sp.bins_per_band.sum() == sp.freqs.size
    assert np.allclose(sp.band_sums(), np.einsum("fb,fij->bij", np.eye(sp.n_bands)[sp.band_of], sp.total))


def test_too_little_data_is_an_error():
    sut, ref = _data(n=3000)
    with pytest.raises(SpectraError, match="too little data"):
        cross_spectra(sut, ref, FS, None, None, (0.005, 1.0))


def test_whole_run_deconvolution_is_exact_in_band():
    """Counts made by a known response come back as the ground velocity."""
    from bayescal.core.response.family import paz_velocity_response
    from bayescal.core.spectra.welch import deconvolve_runs
    rng = np.random.default_rng(3)
    n = 2 ** 15
    ground = rng.standard_normal(n)
    f = np.fft.rfftfreq(n, 1 / FS)
    h = paz_velocity_response(f, 30.0, 0.7, 800.0)
    counts = np.fft.irfft(np.fft.rfft(ground) * h, n=n)
    back = deconvolve_runs(counts[None], FS, lambda x: paz_velocity_response(x, 30.0, 0.7, 800.0)[None],
                           (0.02, 2.0), margin=1000)[0]
    # compare in band, away from the edges, after the same band limitation
    keep = slice(2000, n - 2000)
    from bayescal.core.spectra.welch import band_taper
    want = np.fft.irfft(np.fft.rfft(ground) * band_taper(f, (0.02, 2.0)), n=n)
    assert np.isnan(back[:1000]).all()
    assert np.max(np.abs(back[keep] - want[keep])) < 0.02 * np.std(want)


def test_time_blocks_sum_to_the_totals_and_a_gap_drops_an_empty_block():
    sut, ref = _data(n=80_000)
    sp = cross_spectra(sut, ref, FS, None, None, (0.05, 2.0), nperseg=1024)
    assert sp.block_totals.shape[0] == 16
    assert np.allclose(sp.block_totals.sum(axis=0), sp.total, rtol=1e-5)
    # a gap over the whole fourth block (samples 15000-20000 of 80000)
    sut[0, 14_000:21_000] = np.nan
    gapped = cross_spectra(sut, ref, FS, None, None, (0.05, 2.0), nperseg=1024)
    assert gapped.block_totals.shape[0] == 15
    assert np.bincount(gapped.block_of).min() > 0
    assert np.allclose(gapped.block_totals.sum(axis=0), gapped.total, rtol=1e-5)
    # block numbers follow time
    assert np.all(np.diff(gapped.block_of) >= 0)
