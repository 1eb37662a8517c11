"""Cross-spectral matrices of all channels, per segment, grouped in bands.

Convention (written once, here): for a vector of channel spectra ``Z(f)`` the
cross-spectral matrix is ``C = Z Z^H``, i.e. ``C[i, j] = Z_i conj(Z_j)`` (the
seed's ``X X^H``). scipy's ``csd(x, y)`` returns ``E[conj(X) Y]``, which is
``C[j, i]`` here, the complex conjugate of ``C[i, j]``. Spectra use numpy's
forward FFT (``exp(-2 pi i f t)``), under which a causal filter with Laplace
transform ``H(s)`` multiplies the spectrum by ``H(2 pi i f)``, as ObsPy's
responses assume.

Channels are ordered SUT first, reference second: ``Z = [Y_u; Y_r]``. Every
channel is deconvolved to ground velocity (m/s) by its *nominal* response
(SUT) or its known response (reference); the parametric SUT response then
enters the likelihood as a ratio to the nominal.

Responses are removed from each gap-free run of the record *before* it is cut
into windowed segments (a band-limited inverse, identical for every channel).
Dividing each windowed segment's spectrum by the response instead is only
exact for a response that is flat across the window's kernel: below a
sensor's corner it is not, and that leakage biased fitted periods and
dampings by about 0.1 % (measured on noise-free simulations: 8e-4 per
segment, 1e-5 per run). Samples within two periods of the band's lower edge
from a run's ends, where the inverse filter's transient lives, are left out.

Segments stream through in chunks (:mod:`.segments`: one FFT per channel
and segment), each chunk's spectra summed into the per-frequency totals
(whole record, and 16 time blocks in single precision: 9 times the memory
of the totals alone, F x n x n numbers each) and the small per-segment band
matrices, so memory holds one chunk of segments beyond what the fit keeps;
it does not grow with the record beyond ``K x B x n x n`` numbers and the
record itself (the deconvolution holds one run of one sensor at a time).

Every sum is one of numpy's own loops (``einsum``, ``mean``), none a BLAS
call: the order of its terms is fixed by the arrays' shapes, so the spectra
are the same bits whatever BLAS's thread count (a process-wide setting that
another thread's fit may change meanwhile) and wherever the samples lie in
memory.
"""
from __future__ import annotations

from dataclasses import dataclass, field, replace

import numpy as np
from scipy.fft import next_fast_len

from ...errors import SpectraError
from .segments import gap_free, hann, remove_line, segment_spectra


#: Time blocks kept of the per-frequency totals (see ``CrossSpectra.block_totals``).
TIME_BLOCKS = 16


@dataclass
class CrossSpectra:
    """Segment-summed cross-spectra of SUT and reference channels.

    Attributes
    ----------
    freqs : (F,) frequencies (Hz) inside the analysis band.
    band_edges : (B+1,) band edges (Hz); ``band_of`` (F,) gives each bin's band.
    total : (F, n, n) sum over used segments of ``Z Z^H`` (ground units).
    per_segment : (K, B, n, n) the same summed within each band, per segment:
        the raw material of the noise model and of the diagnostics.
    segment_starts : (K,) first sample of each used segment.
    block_totals : (G, F, n, n) ``total`` split into G consecutive time blocks
        of equal length, those a gap left empty dropped (``block_of`` (K,)
        gives each segment's block); single precision (16 blocks cost 8
        times the memory of ``total``): what a model of a clock that drifts
        through the record needs.
    response_power : (n, F) ``|H(f)|^2`` of each channel's (nominal) response
        at ``freqs`` (None for channels already in ground units): the shape
        self-noise white in counts has in ground units, for the
        errors-in-variables model.
    n_u, n_r : numbers of SUT and reference channels.
    psd_scale : multiply ``total / K`` by this to get one-sided PSD, (m/s)^2/Hz.
    """

    fs: float
    nperseg: int
    step: int
    freqs: np.ndarray
    band_edges: np.ndarray
    band_of: np.ndarray
    total: np.ndarray
    per_segment: np.ndarray
    segment_starts: np.ndarray
    n_u: int
    n_r: int
    n_segments_possible: int
    psd_scale: float
    sut_ids: list = field(default_factory=list)
    ref_ids: list = field(default_factory=list)
    block_totals: np.ndarray | None = None
    block_of: np.ndarray | None = None
    response_power: np.ndarray | None = None

    @property
    def n_segments(self):
        return int(self.per_segment.shape[0])

    @property
    def n_bands(self):
        return int(self.band_edges.size - 1)

    @property
    def band_centres(self):
        return np.sqrt(self.band_edges[:-1] * self.band_edges[1:])

    @property
    def bins_per_band(self):
        return np.bincount(self.band_of, minlength=self.n_bands)

    def band_sums(self):
        """(B, n, n) sum of ``total`` within each band."""
        return self.per_segment.sum(axis=0)

    def psd(self):
        """(n, F) one-sided PSD of every channel, (m/s)^2/Hz, nominal responses."""
        d = np.real(np.einsum("fii->if", self.total))
        return d * self.psd_scale / self.n_segments

    def coherence(self, i, j):
        """(F,) magnitude-squared coherence between channels ``i`` and ``j``."""
        c = self.total
        return np.abs(c[:, i, j]) ** 2 / np.real(c[:, i, i] * c[:, j, j])

    def multiple_coherence(self):
        """(n_u, F): squared multiple coherence of each SUT channel with all
        reference channels (the fraction of its power the reference explains)."""
        nu = self.n_u
        cuu = np.real(np.einsum("fii->fi", self.total[:, :nu, :nu]))
        cur = self.total[:, :nu, nu:]
        crr_inv = np.linalg.inv(self.total[:, nu:, nu:])
        expl = np.real(np.einsum("fij,fjk,fik->fi", cur, crr_inv, cur.conj()))
        return (expl / cuu).T

    def segment_times(self):
        """(K,) centre time of each used segment, seconds from the record's start."""
        return (self.segment_starts + self.nperseg / 2.0) / self.fs

    def block_times(self):
        """(G,) mean centre time of the segments of each time block of
        ``block_totals`` (seconds from the record's start)."""
        g = self.block_totals.shape[0]
        count = np.maximum(np.bincount(self.block_of, minlength=g), 1)
        return np.bincount(self.block_of, self.segment_times(), g) / count

    @property
    def fraction_used(self):
        return self.n_segments / max(self.n_segments_possible, 1)

    def select(self, sut_index):
        """The same spectra restricted to the SUT channels ``sut_index``."""
        sut_index = list(sut_index)
        keep = sut_index + list(range(self.n_u, self.n_u + self.n_r))
        ix = np.ix_(keep, keep)
        return replace(
            self, total=self.total[:, ix[0], ix[1]],
            per_segment=self.per_segment[:, :, ix[0], ix[1]], n_u=len(sut_index),
            block_totals=(None if self.block_totals is None
                          else self.block_totals[:, :, ix[0], ix[1]]),
            sut_ids=[self.sut_ids[i] for i in sut_index] if self.sut_ids else [],
            response_power=(None if self.response_power is None
                            else self.response_power[keep]))


#: A band split into fewer noise bands than this is narrow (:func:`make_bands`).
MIN_NOISE_BANDS = 3
#: Fewest bins a noise band of a narrow band may hold.
NARROW_MIN_BINS = 4
#: Fewest half-overlapping segments a narrow band's longer segments must leave.
NARROW_MIN_SEGMENTS = 12


def default_nperseg(fs, fmin, n_samples, cycles=10, min_cycles=4, min_segments=24, fmax=None):
    """Power-of-two segment length: ``cycles`` periods of ``fmin`` (so the
    lowest band holds enough bins), halved while the record would give fewer
    than ``min_segments`` half-overlapping segments, but never below
    ``min_cycles`` periods. Many segments make the plug-in noise model (and so
    the credible intervals) reliable; long ones keep window leakage small.

    A narrow band (``fmax`` given) is then given longer segments while it
    holds fewer than ``MIN_NOISE_BANDS x NARROW_MIN_BINS`` bins and at least
    :data:`NARROW_MIN_SEGMENTS` segments remain: its noise model can then
    follow the noise across the band in :data:`MIN_NOISE_BANDS` bands
    (:func:`make_bands`) instead of one, whose single noise level gives the
    bins where the signal is weak and the noise strong the weight of the
    strong ones."""
    want = int(2 ** np.ceil(np.log2(cycles * fs / fmin)))
    while want / 2 >= min_cycles * fs / fmin and 2 * n_samples / want - 1 < min_segments:
        want //= 2
    if fmax is not None:
        def n_bins(n):
            f = np.fft.rfftfreq(n, 1.0 / fs)
            return int(np.count_nonzero((f >= fmin) & (f <= fmax)))
        while (n_bins(want) < MIN_NOISE_BANDS * NARROW_MIN_BINS
               and 2 * n_samples / (2 * want) - 1 >= NARROW_MIN_SEGMENTS):
            want *= 2
    return want


def make_bands(freqs, fmin, fmax, bands_per_decade=6, min_bins=8):
    """Log-spaced band edges within [fmin, fmax]; a band with fewer than
    ``min_bins`` bins is merged with its upper neighbour. A narrow band that
    this leaves in fewer than :data:`MIN_NOISE_BANDS` bands is split into
    that many, or as many as hold :data:`NARROW_MIN_BINS` bins each (equal
    in log frequency, merged as above)."""
    n = max(1, int(np.ceil(np.log10(fmax / fmin) * bands_per_decade)))
    edges = _log_bands(freqs, fmin, fmax, n, min_bins)
    if edges.size - 1 < MIN_NOISE_BANDS and min_bins > NARROW_MIN_BINS:
        want = min(MIN_NOISE_BANDS, np.asarray(freqs).size // NARROW_MIN_BINS)
        if want > edges.size - 1:
            finer = _log_bands(freqs, fmin, fmax, want, NARROW_MIN_BINS)
            if finer.size > edges.size:
                edges = finer
    return edges


def _log_bands(freqs, fmin, fmax, n, min_bins):
    edges = list(np.geomspace(fmin, fmax, n + 1))
    merged = [edges[0]]
    for hi in edges[1:]:
        cnt = np.count_nonzero((freqs >= merged[-1]) & (freqs < hi))
        if cnt >= min_bins or hi == edges[-1]:
            merged.append(hi)
    # the last band may be too thin: merge it downward
    if len(merged) > 2:
        cnt = np.count_nonzero((freqs >= merged[-2]) & (freqs < merged[-1]))
        if cnt < min_bins:
            del merged[-2]
    return np.asarray(merged)


def band_taper(freqs, band):
    """1 inside ``band``, cosine ramps over an octave on each side, 0 beyond."""
    lo, hi = band
    f = np.asarray(freqs, float)
    t = np.zeros_like(f)
    t[(f >= lo) & (f <= hi)] = 1.0
    up = (f >= lo / 2) & (f < lo)
    t[up] = 0.5 - 0.5 * np.cos(np.pi * (f[up] - lo / 2) / (lo / 2))
    down = (f > hi) & (f <= 2 * hi)
    t[down] = 0.5 + 0.5 * np.cos(np.pi * (f[down] - hi) / hi)
    return t


def deconvolve_runs(data, fs, response, band, margin, out=None):
    """Ground velocity from counts, run by run (runs of finite samples): a
    band-limited inverse of ``response`` (``band_taper`` around ``band``)
    applied with a zero-padded FFT; ``margin`` samples at each end of every
    run are set to NaN (the inverse filter's transient). Written into
    ``out`` (an array of ``data``'s shape) when given."""
    if out is None:
        out = np.empty(np.shape(data))
    if response is None:                      # already ground velocity
        out[...] = data
        return out
    out[...] = np.nan
    finite = np.all(np.isfinite(data), axis=0).astype(np.int8)
    edges = np.flatnonzero(np.diff(np.r_[0, finite, 0]))
    cache = {}
    for a, b in zip(edges[::2], edges[1::2]):
        n = b - a
        if n <= 2 * margin:
            continue
        nfft = next_fast_len(2 * n)
        if nfft not in cache:
            f = np.fft.rfftfreq(nfft, 1.0 / fs)
            taper = band_taper(f, band)
            use = slice(np.argmax(taper > 0), taper.size - np.argmax(taper[::-1] > 0))
            cache[nfft] = (use, taper[use] / np.atleast_2d(response(f[use])))
        use, inverse = cache[nfft]
        for row in range(out.shape[0]):                 # one channel at a time
            spec = np.fft.rfft(remove_line(np.array(data[row, a:b], dtype=float)), n=nfft)
            spec[:use.start] = 0
            spec[use.stop:] = 0
            spec[use] *= inverse[row % inverse.shape[0]]
            out[row, a + margin:b - margin] = np.fft.irfft(spec, n=nfft)[margin:n - margin]
    return out


def cross_spectra(sut, ref, fs, sut_response, ref_response, band, *, nperseg=None, overlap=0.5,
                  bands_per_decade=6, min_bins=8, chunk=None, sut_ids=(), ref_ids=(),
                  edge_periods=2.0, time_blocks=TIME_BLOCKS, exclude=None):
    """Compute :class:`CrossSpectra` from SUT and reference samples.

    Parameters
    ----------
    sut, ref : arrays (n_u, N) and (n_r, N) in counts on a common time grid.
        NaN marks missing samples: a segment touching one is dropped.
    fs : sampling rate (Hz).
    sut_response, ref_response : callables ``freqs -> (n, F)`` complex
        velocity responses (counts per m/s); nominal for the SUT. ``None``
        when the data are already ground velocity (no deconvolution).
    band : (fmin, fmax) analysis band (Hz).
    nperseg : segment length (samples); default from :func:`default_nperseg`.
    overlap : fraction of segment overlap (Welch), 0.5 by default.
    chunk : segments transformed at once; None: as many as hold
        :data:`~bayescal.core.spectra.segments.CHUNK_BYTES` of samples.
    edge_periods : periods of the band's lower edge left out at the ends of
        every gap-free run (the deconvolution's transient).
    time_blocks : number of equal time blocks of ``block_totals``.
    exclude : first samples of segments to leave out (as ``segment_starts``
        gives them; e.g. the transients of :mod:`bayescal.core.spectra.transients`),
        or None.
    """
    sut, ref, fmin, fmax = _checked_inputs(sut, ref, fs, band)
    n_samples = sut.shape[1]
    nperseg = int(nperseg or default_nperseg(fs, fmin, n_samples, fmax=fmax))
    step = max(1, int(round(nperseg * (1 - overlap))))
    if n_samples < nperseg + 3 * step:
        raise SpectraError(
            f"too little data for the band: {n_samples / fs:.0f} s recorded, the band's lower "
            f"edge {fmin:g} Hz needs segments of {nperseg / fs:.0f} s and at least 4 of them")
    bins, freqs, edges, band_of, bounds = _band_grid(fs, nperseg, fmin, fmax, bands_per_decade,
                                                     min_bins)
    margin = int(round(edge_periods * fs / fmin))
    data = np.empty((sut.shape[0] + ref.shape[0], n_samples))
    deconvolve_runs(sut, fs, sut_response, (fmin, fmax), margin, out=data[:sut.shape[0]])
    deconvolve_runs(ref, fs, ref_response, (fmin, fmax), margin, out=data[sut.shape[0]:])
    win = hann(nperseg, sym=False)
    starts = np.arange(0, n_samples - nperseg + 1, step)
    total, per_segment, segment_starts, blocks, block_of = _accumulate(
        data, starts, win, bins, bounds, chunk=chunk, exclude=exclude,
        time_blocks=time_blocks, n_samples=n_samples)
    if per_segment.shape[0] < 4:
        raise SpectraError(f"only {per_segment.shape[0]} gap-free segments of {nperseg / fs:.0f} s:"
                           " too little data for the band")
    if not np.all(np.isfinite(total)):
        raise SpectraError("the cross-spectra overflow: samples or responses far beyond any "
                           "recording's (a corrupted file or metadata value?)")
    power = [np.ones((x.shape[0], freqs.size)) if fn is None else np.abs(fn(freqs)) ** 2
             for fn, x in ((sut_response, sut), (ref_response, ref))]
    return CrossSpectra(
        response_power=np.vstack(power),
        fs=float(fs), nperseg=nperseg, step=step, freqs=freqs, band_edges=edges, band_of=band_of,
        total=total, per_segment=per_segment, segment_starts=segment_starts,
        n_u=sut.shape[0], n_r=ref.shape[0], n_segments_possible=int(starts.size),
        psd_scale=2.0 / (fs * np.sum(win ** 2)), sut_ids=list(sut_ids), ref_ids=list(ref_ids),
        block_totals=blocks, block_of=block_of)


def _checked_inputs(sut, ref, fs, band):
    """The SUT and reference as 2-D float arrays and the band's edges, or a
    :class:`SpectraError` on arrays of different lengths or a band outside
    ``(0, fs / 2]``."""
    sut = np.atleast_2d(np.asarray(sut, dtype=float))
    ref = np.atleast_2d(np.asarray(ref, dtype=float))
    if sut.shape[1] != ref.shape[1]:
        raise SpectraError("SUT and reference arrays differ in length")
    why = band_refusal(band, fs)
    if why:
        raise SpectraError(why)
    fmin, fmax = map(float, band)
    return sut, ref, fmin, fmax


def band_refusal(band, fs):
    """Why the spectra refuse the band ``(fmin, fmax)`` (Hz) of a record
    sampled at ``fs``, or None when they accept it: the one rule
    :func:`cross_spectra` applies, which the criticism's advice is checked
    against."""
    fmin, fmax = map(float, band)
    if not 0 < fmin < fmax:
        return f"band {tuple(band)} is not a positive interval"
    if fmax > fs / 2:
        return f"band upper edge {fmax} Hz is above Nyquist ({fs / 2} Hz)"
    return None


def _band_grid(fs, nperseg, fmin, fmax, bands_per_decade, min_bins):
    """The segment's frequencies in the band: ``(bins, freqs, edges,
    band_of, bounds)``, their slice of the FFT grid, the frequencies, the
    averaging bands' edges, each frequency's band and each band's first bin."""
    all_f = np.fft.rfftfreq(nperseg, 1.0 / fs)
    bins = slice(np.searchsorted(all_f, fmin, "left"), np.searchsorted(all_f, fmax, "right"))
    freqs = all_f[bins]
    edges = make_bands(freqs, fmin, fmax, bands_per_decade, min_bins)
    band_of = np.clip(np.searchsorted(edges, freqs, side="right") - 1, 0, edges.size - 2)
    bounds = np.r_[0, np.flatnonzero(np.diff(band_of)) + 1]
    return bins, freqs, edges, band_of, bounds


def _accumulate(data, starts, win, bins, bounds, *, chunk, exclude, time_blocks, n_samples):
    """Sum the windowed segments' cross-products: ``(total, per_segment,
    segment_starts, blocks, block_of)``, the sum over gap-free segments, each
    segment's sums over the averaging bands, the segments' first samples,
    the sums over time blocks (those a gap left empty dropped) and each
    segment's block."""
    nperseg = win.size
    n_blocks = max(1, min(int(time_blocks), starts.size // 2))
    block_of_start = np.minimum((starts * n_blocks) // max(n_samples - nperseg + 1, 1), n_blocks - 1)
    ok = gap_free(data, starts, nperseg)
    if exclude is not None:
        ok &= ~np.isin(starts, exclude)
    if not ok.any():
        raise SpectraError("no segment without gaps: every window touches missing data")
    segment_starts, block_of = starts[ok], block_of_start[ok]
    n, n_f = data.shape[0], bins.stop - bins.start
    total = np.zeros((n_f, n, n), dtype=complex)
    blocks = np.zeros((n_blocks,) + total.shape, dtype=np.complex64)
    per_segment = np.empty((segment_starts.size, bounds.size, n, n), dtype=complex)
    band_bins = [slice(a, b) for a, b in zip(bounds, np.r_[bounds[1:], n_f])]
    for c0, z in segment_spectra(data, segment_starts, win, bins, chunk):   # (k, n, F), m/s
        k = z.shape[0]
        for b, fb in enumerate(band_bins):
            zb = z[:, :, fb]
            per_segment[c0:c0 + k, b] = np.einsum("kif,kjf->kij", zb, zb.conj())
        ids = block_of[c0:c0 + k]
        for g in np.unique(ids):
            zg = z[ids == g]
            part = np.einsum("kif,kjf->fij", zg, zg.conj())
            total += part
            blocks[g] += part
    # blocks that a gap left empty are dropped (numbered anew)
    filled = np.bincount(block_of, minlength=n_blocks) > 0
    blocks, block_of = blocks[filled], (np.cumsum(filled) - 1)[block_of]
    return total, per_segment, segment_starts, blocks, block_of
