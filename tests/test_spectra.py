"""Cross-spectra: convention against scipy, gaps, chunking, band layout."""
import numpy as np
import pytest
from scipy.signal import csd

from bayescal.errors import SpectraError
from bayescal.core.spectra.welch import cross_spectra

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


def test_a_narrow_band_is_split_into_three_noise_bands():
    """ASL's azimuth band 1/8-1/3 Hz with 64-s segments holds 14 bins: six
    bands a decade with eight bins each would leave one noise level for
    bins whose noise differs five-fold on COWI; it is split in three."""
    from bayescal.core.spectra.welch import make_bands
    f = np.fft.rfftfreq(64, 1.0)
    f = f[(f >= 1 / 8) & (f <= 1 / 3)]
    edges = make_bands(f, 1 / 8, 1 / 3)
    assert edges.size == 4
    counts = np.histogram(f, edges)[0]
    assert counts.sum() == f.size and counts.min() >= 4
    # too few bins for three bands of four: as many as hold four
    assert make_bands(f[:9], 1 / 8, f[8]).size == 3


def test_a_wide_band_keeps_six_bands_a_decade_of_eight_bins():
    from bayescal.core.spectra.welch import make_bands
    f = np.fft.rfftfreq(2048, 0.1)
    f = f[(f >= 0.02) & (f <= 2.0)]
    edges = make_bands(f, 0.02, 2.0)
    counts = np.histogram(f, edges)[0]
    assert counts.min() >= 8
    # the lowest bands merge upward until they hold eight bins; above, one per sixth of a decade
    assert np.allclose(edges[-8:], np.geomspace(0.02, 2.0, 13)[-8:])


def test_segments_lengthen_for_a_narrow_band_while_enough_remain():
    from bayescal.core.spectra.welch import default_nperseg
    # ten minutes at 1 Hz: 32-s segments give 36 of them but 7 bins in 1/8-1/3 Hz
    assert default_nperseg(1.0, 1 / 8, 600) == 32
    assert default_nperseg(1.0, 1 / 8, 600, fmax=1 / 3) == 64        # 14 bins, 17 segments
    assert default_nperseg(1.0, 1 / 8, 300, fmax=1 / 3) == 32        # 64 s would leave 8
    assert default_nperseg(10.0, 0.02, 36_000, fmax=2.0) == default_nperseg(10.0, 0.02, 36_000)


def _stft_truth(data, fs, nperseg):
    """(K, n, F) windowed, linearly detrended segment spectra by scipy's
    ``stft`` (half-overlapping Hann segments, no padding), in the units of
    ``cross_spectra`` (``stft`` divides by the window's sum)."""
    from scipy.signal import stft
    from scipy.signal.windows import hann
    _, _, z = stft(data, fs, window="hann", nperseg=nperseg, noverlap=nperseg // 2,
                   detrend="linear", boundary=None, padded=False)
    return np.moveaxis(z, -1, 0) * hann(nperseg, sym=False).sum()


@pytest.mark.parametrize("chunk", [None, 1, 3])
def test_segment_band_and_block_sums_match_scipy_stft(chunk):
    """Every segment's band matrices, the totals and the time blocks equal
    sums of ``Z Z^H`` over scipy's segment spectra, whatever the chunking
    (chunks of 3 segments split blocks of 2-3 segments), with a gap."""
    sut, ref = _data(n=20_000)
    sut[1, 7_000:7_010] = np.nan
    sp = cross_spectra(sut, ref, FS, None, None, (0.05, 2.0), nperseg=512, chunk=chunk)
    # the segments touching the gap are left out: zeros there change no segment kept
    z = _stft_truth(np.nan_to_num(np.vstack([sut, ref])), FS, 512)[sp.segment_starts // sp.step]
    all_f = np.fft.rfftfreq(512, 1 / FS)
    z = z[:, :, (all_f >= 0.05) & (all_f <= 2.0)]                  # (K, n, F)
    prod = np.einsum("kif,kjf->kfij", z, z.conj())
    assert sp.n_segments_possible - sp.n_segments == 2
    np.testing.assert_allclose(sp.total, prod.sum(axis=0), rtol=1e-12, atol=1e-12 * np.abs(prod).max())
    bands = np.eye(sp.n_bands)[sp.band_of]                          # (F, B)
    want = np.einsum("kfij,fb->kbij", prod, bands)
    np.testing.assert_allclose(sp.per_segment, want, rtol=1e-12, atol=1e-12 * np.abs(want).max())
    blocks = np.stack([prod[sp.block_of == g].sum(axis=0) for g in range(sp.block_totals.shape[0])])
    np.testing.assert_allclose(sp.block_totals, blocks, rtol=1e-6, atol=1e-6 * np.abs(blocks).max())


def test_line_removal_and_gap_test_match_their_definitions():
    from scipy.signal import detrend
    from bayescal.core.spectra.segments import gap_free, remove_line
    rng = np.random.default_rng(5)
    noise = rng.standard_normal((2, 3, 1000))
    # a line plus noise less its line: the noise less its own line (scipy's, on the noise alone)
    x = 1e4 + 3.0 * np.arange(1000) / 1000 + noise
    np.testing.assert_allclose(remove_line(x), detrend(noise, type="linear"), rtol=0, atol=1e-11)
    data = rng.standard_normal((2, 1000))
    data[1, 500] = np.inf
    starts = np.arange(0, 1000 - 100 + 1, 50)
    want = [np.all(np.isfinite(data[:, s:s + 100])) for s in starts]
    np.testing.assert_array_equal(gap_free(data, starts, 100), want)


def test_memory_holds_the_results_and_one_chunk():
    """The cross-spectra's peak memory: the record twice (the samples and
    their deconvolved copy), the results, and one chunk of segments (samples,
    spectra, one temporary): never a segments x frequencies x n x n array."""
    import tracemalloc
    from bayescal.core.spectra.segments import CHUNK_BYTES
    rng = np.random.default_rng(1)
    x = rng.standard_normal((6, 150_000))
    tracemalloc.start()
    try:
        sp = cross_spectra(x[:3], x[3:], FS, None, None, (0.02, 4.9), nperseg=4096)
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    kept = sp.total.nbytes + sp.block_totals.nbytes + sp.per_segment.nbytes
    assert sp.n_segments * sp.freqs.size * 36 * 16 > 8 * CHUNK_BYTES    # what is never held
    assert peak < 2 * x.nbytes + kept + 3.5 * CHUNK_BYTES, (peak / 2**20, kept / 2**20)


def _at_offset(x, offset):
    """A copy of ``x`` whose data start ``offset`` bytes past a 64-byte boundary."""
    buf = np.empty(x.nbytes + 128, np.uint8)
    start = (-buf.ctypes.data) % 64 + offset
    out = buf[start:start + x.nbytes].view(x.dtype).reshape(x.shape)
    out[...] = x
    return out


def test_spectra_are_the_same_bits_on_one_or_two_blas_threads_and_any_alignment():
    """The cross-spectra are sums in an order of the code's choosing: the
    same bits whatever BLAS's thread count (a process-wide setting that
    another thread's fit may change while these spectra are computed) and
    wherever the samples lie in memory. A record of 36 000 samples per
    channel, deconvolved: OpenBLAS's dot product of two such vectors sums in
    two halves on two threads, so a BLAS dot anywhere on the path shows."""
    from threadpoolctl import threadpool_limits
    from bayescal.core.response.family import paz_velocity_response
    sut, ref = _data(n=36_000)
    sut[0, 20_000:20_020] = np.nan                           # two runs, each deconvolved alone

    def resp(n):
        return lambda f: np.repeat(paz_velocity_response(f, 30.0, 0.7, 800.0)[None], n, axis=0)

    def digest(s, r, threads):
        with threadpool_limits(limits=threads, user_api="blas"):
            sp = cross_spectra(s, r, FS, resp(2), resp(1), (0.05, 2.0), nperseg=1024)
        return [a.tobytes() for a in (sp.total, sp.per_segment, sp.block_totals)]

    want = digest(sut, ref, 1)
    for threads, offset in ((2, 0), (1, 8), (2, 24), (1, 40)):
        got = digest(_at_offset(sut, offset), _at_offset(ref, offset + 16), threads)
        assert got == want, (threads, offset)
