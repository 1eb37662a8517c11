"""Coil-by-coil calibration of symmetric triaxial (UVW) sensors (seed 003).

Geometry and conventions (written down once, here)
--------------------------------------------------
``M`` is the UVW matrix of :mod:`bayescal.geometry`: rows U, V, W over
columns X, Y, Z of the sensor frame (X = channel 1/N, Y = channel 2/E,
Z = vertical, positive up). Row ``n`` is element ``n``'s sensitive axis in
XYZ, so an element's output is ``u_n = M[n] . x`` and the sensor's XYZ
outputs are ``x = M^T u`` (the seed's ``a = M a'`` with the seed's matrix
being our ``M^T``). ``M`` is orthonormal, so ``M^-1 = M^T``.

* STS-2 (Streckeisen STS-2 manual): ``X = (-2U + V + W)/sqrt 6``,
  ``Y = (V - W)/sqrt 2``, ``Z = (U + V + W)/sqrt 3``: U leans toward -X.
* Trillium (Nanometrics Trillium 120/240 manuals): ``X = (2U - V - W)/sqrt 6``,
  the same with the X column negated: U leans toward +X. Elements sit at
  ``arccos(1/sqrt 3) = 54.7356`` degrees from the vertical, 120 degrees apart
  in azimuth.

With element responses ``k_n(f)`` the sensor's XYZ response matrix is
``M^T diag(k) M``; its diagonal is the seed's ``g_l = sum_j M_jl^2 k_j`` and
its off-diagonal terms are the cross-talk, zero only when the elements agree.

Model of a calibration run
--------------------------
Run ``n`` drives element ``n``'s coil with ``u(t)`` counts, an equivalent
ground acceleration ``C u`` (``C`` the coil constant) along the element's axis.
Each recorded output ``c`` (XYZ, or UVW when the sensor is switched to UVW
mode) is

    X_c(f) = m_c K_n(f) A(f) + N_c(f),   A(f) = C U(f) / (2 pi i f)  (velocity),

with ``m_c = M[n, c]`` (XYZ outputs) or ``delta_nc`` (UVW outputs) and
``K_n = H_c,nom * rho_c(f; T_n, h_n, G_n)``: channel c's nominal response with
its two long-period poles and first-stage gain replaced by the element's
(:class:`bayescal.response.TwoPoleFamily`). Outputs are deconvolved to m/s by
their nominal response and the input to m/s by ``2 pi i f / C`` through
:func:`bayescal.spectra.cross_spectra` (Welch, Hann, 50 % overlap). The
residual per narrow band b (20 per decade) is

    R_b,c(theta) = sum_{f in b} [ Y_c A^* - m_c rho_c(f; theta) |A|^2 ],

zero-mean at the truth; its covariance is ``c_b Sigma_b S_AA,b`` with
``Sigma_b`` the per-bin covariance of the output residual (full matrix across
outputs: element noise mixes into X, Y, Z) and ``c_b`` the ratio of the
scatter of per-segment band residuals (with the lag-one term of overlapping
segments) to the independent-bin formula, shrunk toward its pooled value, as
in :mod:`bayescal.likelihood`. After the least-squares fit the spectra are
recomputed deconvolved by the fitted response, so the per-segment residuals
that calibrate ``c_b`` are free of in-band model curvature.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from scipy.optimize import least_squares

from .fit import FitError, sample
from .geometry import STS2_UVW, TRILLIUM_UVW
from .io import InputError
from .likelihood import INFLATION_SHRINK, Priors
from .posterior import interval_summary
from .response import ResponseError, TwoPoleFamily, evaluate_velocity_response
from .spectra import SpectraError, cross_spectra

SCHEMA = "bayescal.uvw/1"
ELEMENTS = ("U", "V", "W")
XYZ = ("X", "Y", "Z")
PARAMS = ("period_s", "damping", "gain")
#: Narrow bands: the response ratio barely changes within one.
BANDS_PER_DECADE = 20
#: Segments hold this many periods of the band's lower edge (power of two):
#: long enough that window leakage does not bias the element's period.
SEGMENT_CYCLES = 10
#: |z| above which Z-only and all-output estimates are called inconsistent.
#: Calibrated by benchmarks/uvw_coverage.py: under the true model the
#: statistic's sd is 1.14-1.17 per parameter and its largest |z| in 360 draws
#: 3.7, so 4 keeps false alarms near 1 % per nine-parameter calibration.
AGREEMENT_Z = 4.0

SENSORS = {
    "sts2": (STS2_UVW, "Streckeisen STS-2 manual: X=(-2U+V+W)/sqrt6, Y=(V-W)/sqrt2, "
                       "Z=(U+V+W)/sqrt3 (bayescal.geometry.STS2_UVW)"),
    "trillium": (TRILLIUM_UVW, "Nanometrics Trillium manuals: X=(2U-V-W)/sqrt6, Y=(V-W)/sqrt2, "
                               "Z=(U+V+W)/sqrt3 (bayescal.geometry.TRILLIUM_UVW)"),
}


# --- geometry ---------------------------------------------------------------

def sensor_matrix(name):
    """Built-in UVW matrix and its source for ``"sts2"`` or ``"trillium"``."""
    try:
        m, src = SENSORS[name.lower()]
    except KeyError:
        raise InputError(f"unknown sensor {name!r}: choose one of {sorted(SENSORS)} "
                         "or give --matrix FILE") from None
    return np.array(m, float), src


def load_matrix(path):
    """Read a 3x3 UVW matrix (rows U, V, W over columns X, Y, Z) from a text
    file: whitespace- or comma-separated numbers, ``#`` comments. It must be
    orthonormal (to 1e-3), else :class:`InputError` naming the file."""
    try:
        with open(path) as fh:
            rows = [ln.split("#", 1)[0].replace(",", " ").split() for ln in fh]
        m = np.array([[float(x) for x in r] for r in rows if r], float)
    except (OSError, ValueError) as exc:
        raise InputError(f"{path}: cannot read a 3x3 matrix ({exc})") from None
    if m.shape != (3, 3):
        raise InputError(f"{path}: expected 3 rows of 3 numbers (U, V, W over X, Y, Z), "
                         f"found shape {m.shape}")
    err = np.abs(m @ m.T - np.eye(3)).max()
    if err > 1e-3:
        raise InputError(f"{path}: the matrix is not orthonormal (|M M^T - I| = {err:.3g})")
    return m


def response_matrix(k, m):
    """XYZ response matrix ``M^T diag(k) M`` for element responses ``k`` of
    shape ``(..., 3, F)``; returns ``(..., 3, 3, F)`` (rows, columns X, Y, Z)."""
    return np.einsum("jl,jm,...jf->...lmf", m, m, k)


def seed_xyz_diagonal(h3, m):
    """The seed's Z-only algebra: ``g_l = sum_j M_jl^2 h^j_3 / M_j3`` from the
    Z outputs ``h3`` of the runs driving U, V, W (first axis: the element;
    any further axes, e.g. frequency, are carried along). Returns the XYZ
    diagonal responses, first axis X, Y, Z."""
    w = m * m / m[:, 2][:, None]
    return np.tensordot(w, np.asarray(h3), axes=(0, 0))


def cross_talk(t):
    """Largest relative cross-talk ``|T_lm| / sqrt(|T_ll T_mm|)`` (l != m) of
    response matrices ``t`` (``(..., 3, 3, F)``), over pairs and frequencies;
    returns ``(values (...,), pair index (...,) into (XY, XZ, YZ))``."""
    d = np.abs(np.einsum("...llf->...lf", t))
    pairs = [(0, 1), (0, 2), (1, 2)]
    rel = np.stack([np.abs(t[..., i, j, :]) / np.sqrt(d[..., i, :] * d[..., j, :])
                    for i, j in pairs], axis=-2)                     # (..., 3, F)
    per_pair = rel.max(axis=-1)
    return per_pair.max(axis=-1), per_pair.argmax(axis=-1)


# --- XYZ <-> UVW rotation of recorded data -----------------------------------

_AXIS_OF = {"N": "X", "1": "X", "E": "Y", "2": "Y", "Z": "Z", "U": "U", "V": "V", "W": "W"}


def output_axis(channel_code):
    """Sensor axis (X, Y, Z, U, V or W) of an output channel, from the last
    letter of its SEED code (N/1 -> X, E/2 -> Y, Z, U, V, W), else None."""
    return _AXIS_OF.get(channel_code[-1:].upper()) if len(channel_code) == 3 else None


def _rotate(stream, m, from_axes, to_axes, source):
    st = stream.copy()
    st.merge(method=0, fill_value=None)
    found = {}
    for tr in st:
        ax = output_axis(tr.stats.channel)
        if ax in from_axes:
            if ax in found:
                raise InputError(f"{source}: two channels for axis {ax}")
            found[ax] = tr
    missing = [a for a in from_axes if a not in found]
    if missing:
        raise InputError(f"{source}: no channel for axis {', '.join(missing)} "
                         f"(channels: {', '.join(tr.id for tr in st)})")
    trs = [found[a] for a in from_axes]
    if len({tr.stats.sampling_rate for tr in trs}) != 1:
        raise InputError(f"{source}: the three channels have different sampling rates")
    t0 = max(tr.stats.starttime for tr in trs)
    t1 = min(tr.stats.endtime for tr in trs)
    if t1 <= t0:
        raise InputError(f"{source}: the three channels do not overlap in time")
    for tr in trs:
        tr.trim(t0, t1, nearest_sample=True)
    n = min(tr.stats.npts for tr in trs)
    x = np.array([np.ma.filled(np.ma.masked_invalid(np.ma.asarray(tr.data[:n], float)), np.nan)
                  for tr in trs])
    y = m @ x
    out = st.__class__()
    for k, ax in enumerate(to_axes):
        tr = trs[0].copy()
        tr.data = np.ma.masked_invalid(y[k]) if np.isnan(y[k]).any() else y[k]
        tr.stats.channel = trs[0].stats.channel[:2] + ax
        out.append(tr)
    return out


def xyz_to_uvw(stream, m=STS2_UVW, source="stream"):
    """Rotate recorded X, Y, Z (channels ?H1/?HN, ?H2/?HE, ?HZ) to the
    element axes: ``u = M x``. Returns a Stream with channels ?HU, ?HV, ?HW
    (same units as the input; gaps stay masked)."""
    return _rotate(stream, np.asarray(m, float), XYZ, ELEMENTS, source)


def uvw_to_xyz(stream, m=STS2_UVW, source="stream"):
    """Inverse of :func:`xyz_to_uvw`: ``x = M^T u``; channels ?HN... are named
    ?H1, ?H2, ?HZ (X, Y, Z of the sensor frame)."""
    st = _rotate(stream, np.asarray(m, float).T, ELEMENTS, XYZ, source)
    for tr, code in zip(st, "12Z"):
        tr.stats.channel = tr.stats.channel[:2] + code
    return st


# --- reading one calibration run --------------------------------------------

@dataclass
class CalRun:
    """One run: element ``element`` driven, its outputs and input aligned."""

    element: str
    source: str
    axes: list            # per output: X, Y, Z, U, V or W
    ids: list
    data: np.ndarray      # (n_out, N) counts, NaN in gaps
    input: np.ndarray     # (N,) counts
    fs: float
    responses: list       # ObsPy Response per output
    families: list        # TwoPoleFamily per output
    cache: dict = field(default_factory=dict, repr=False)   # nominal responses by (id, grid)

    def nominal_response(self, freqs):
        """(n_out, F) nominal velocity responses (counts per m/s), cached."""
        key = (freqs.size, float(freqs[0]), float(freqs[-1]))
        for cid, r in zip(self.ids, self.responses):
            if (cid, key) not in self.cache:
                self.cache[(cid, key)] = evaluate_velocity_response(r, freqs)
        return np.array([self.cache[(cid, key)] for cid in self.ids])

    def select(self, axes):
        """The same run restricted to the outputs on ``axes``."""
        keep = [i for i, a in enumerate(self.axes) if a in axes]
        return CalRun(self.element, self.source, [self.axes[i] for i in keep],
                      [self.ids[i] for i in keep], self.data[keep], self.input, self.fs,
                      [self.responses[i] for i in keep], [self.families[i] for i in keep],
                      self.cache)

    def coefficients(self, m):
        """``m_c`` per output: ``M[n, c]`` for XYZ outputs, ``delta_nc`` for UVW."""
        n = ELEMENTS.index(self.element)
        return np.array([m[n, XYZ.index(a)] if a in XYZ else float(a == self.element)
                         for a in self.axes])


def _as_float(tr):
    d = tr.data
    if np.ma.isMaskedArray(d):
        return np.ma.filled(d.astype(float), np.nan)
    return d.astype(float)


def read_run(element, stream, inventory, input_channel, source):
    """A :class:`CalRun` from one file's Stream and the SUT Inventory.

    The input channel is matched on its channel code (``BC0``) or full SEED
    id; outputs are all other channels whose code ends in N/E/Z/1/2 (XYZ) or
    U/V/W. Raises :class:`InputError` naming ``source``.
    """
    if element not in ELEMENTS:
        raise InputError(f"{source}: element must be U, V or W, not {element!r}")
    st = stream.copy()
    st.merge(method=0, fill_value=None)
    inp = [tr for tr in st if input_channel in (tr.stats.channel, tr.id)]
    if len(inp) != 1:
        raise InputError(f"{source}: {'no' if not inp else 'more than one'} input channel "
                         f"{input_channel} (channels: {', '.join(tr.id for tr in st) or 'none'})")
    outs = [tr for tr in st if tr is not inp[0] and output_axis(tr.stats.channel)]
    if not outs:
        raise InputError(f"{source}: no sensor output channel (codes ending in N/E/Z/1/2 "
                         "or U/V/W)")
    axes = [output_axis(tr.stats.channel) for tr in outs]
    if len(set(axes)) != len(axes):
        raise InputError(f"{source}: two output channels on one axis ({', '.join(tr.id for tr in outs)})")
    if set(axes) & set(XYZ) and set(axes) & set(ELEMENTS):
        raise InputError(f"{source}: both XYZ and UVW outputs in one run")
    trs = [inp[0]] + outs
    rates = {tr.stats.sampling_rate for tr in trs}
    if len(rates) != 1:
        raise InputError(f"{source}: sampling rates differ between channels: {sorted(rates)} Hz")
    fs = rates.pop()
    t0 = max(tr.stats.starttime for tr in trs)
    t1 = min(tr.stats.endtime for tr in trs)
    if t1 <= t0:
        raise InputError(f"{source}: input and outputs do not overlap in time")
    n = int(np.floor((t1 - t0) * fs)) + 1
    arrays = []
    for tr in trs:
        off = int(round((tr.stats.starttime - t0) * fs))
        x = np.full(n, np.nan)
        src = _as_float(tr)
        lo, hi = max(off, 0), min(off + src.size, n)
        x[lo:hi] = src[lo - off:hi - off]
        arrays.append(x)
    responses, families = [], []
    for tr in outs:
        sel = inventory.select(network=tr.stats.network, station=tr.stats.station,
                               location=tr.stats.location, channel=tr.stats.channel,
                               time=tr.stats.starttime)
        try:
            resp = sel[0][0][0].response
        except IndexError:
            raise InputError(f"{source}: channel {tr.id} is not in the SUT StationXML") from None
        if resp is None or not resp.response_stages:
            raise InputError(f"{source}: channel {tr.id} has no response in the SUT StationXML")
        try:
            families.append(TwoPoleFamily.from_response(resp))
        except ResponseError as exc:
            raise InputError(f"{source}: channel {tr.id}: {exc}") from None
        responses.append(resp)
    order = np.argsort([("XYZUVW").index(a) for a in axes])
    return CalRun(element=element, source=source, axes=[axes[i] for i in order],
                  ids=[outs[i].id for i in order], data=np.array(arrays[1:])[order],
                  input=arrays[0], fs=float(fs), responses=[responses[i] for i in order],
                  families=[families[i] for i in order])


# --- likelihood of one run --------------------------------------------------

def run_spectra(run, coil_constant, band, nperseg=None, base=None):
    """Cross-spectra of a run's outputs (deconvolved by their nominal response
    times ``base(freqs) -> (n_out, F)`` when given) and its input (as ground
    velocity, ``A = C U / (2 pi i f)``). Too little data raises
    :class:`InputError` naming the run's file."""
    try:
        return _run_spectra(run, coil_constant, band, nperseg, base)
    except SpectraError as exc:
        raise InputError(f"{run.source}: {exc}") from None


def default_nperseg(fs, fmin):
    """Segment length (samples) for calibration runs: ``SEGMENT_CYCLES``
    periods of ``fmin`` rounded up to a power of two. Fixed here rather than
    taken from :func:`bayescal.spectra.default_nperseg`, whose choice serves
    ambient-noise records; the coverage benchmark was run with this one."""
    return int(2 ** np.ceil(np.log2(SEGMENT_CYCLES * fs / fmin)))


def _run_spectra(run, coil_constant, band, nperseg, base):
    def out_resp(f):
        h = run.nominal_response(np.asarray(f, float))
        return h if base is None else h * base(f)

    def in_resp(f):
        return (2j * np.pi * np.asarray(f) / coil_constant)[None, :]

    return cross_spectra(run.data, run.input[None, :], run.fs, out_resp, in_resp, band,
                         nperseg=nperseg or default_nperseg(run.fs, band[0]), bands_per_decade=BANDS_PER_DECADE, min_bins=8,
                         sut_ids=run.ids, ref_ids=["input"])


class RunModel:
    """Posterior of one element's ``theta = (ln T, h, ln G)`` from one run.

    ``coef`` is ``m_c`` per output, ``families`` the outputs' parametric
    responses, ``base`` (n_out, F) the response ratio the spectra were
    deconvolved by (ones at first). Vectorised: ``log_prob(theta (W, 3))``.
    """

    names = ("log_period", "damping", "log_gain")
    ndim = 3

    def __init__(self, spectra, coef, families, nominal, priors=Priors(), base=None):
        self.spectra = spectra
        self.coef = np.asarray(coef, float)
        self.families = families
        self.nominal = nominal
        self.priors = priors
        no = spectra.n_u
        f = spectra.freqs
        self.base = np.ones((no, f.size), complex) if base is None else base
        t = spectra.total
        self._cya = t[:, :no, no]                                   # (F, no)
        self._saa = t[:, no, no].real                               # (F,)
        self._cyy = t[:, :no, :no]
        self._onehot = np.eye(spectra.n_bands)[spectra.band_of]     # (F, B)
        self._starts = np.r_[0, np.flatnonzero(np.diff(spectra.band_of)) + 1]
        # TwoPoleFamily.ratio split into per-frequency constants and the one
        # factor that depends on (T, h): 1 / D(s; T, h), shared by all outputs
        self._s = 2j * np.pi * f
        self._sn = 2j * np.pi * np.array([fam.norm_freq for fam in families])
        d_nom = np.array([fam._d(self._s, 2 * np.pi / fam.period_s, fam.damping)
                          for fam in families])                       # (no, F)
        self._dn_norm = np.array([abs(fam._d(sn, 2 * np.pi / fam.period_s, fam.damping))
                                  for fam, sn in zip(families, self._sn)])
        self._g_nom = np.array([fam.gain for fam in families])
        self._const = d_nom / self.base                               # (no, F)
        self._kernel = self.coef[:, None] * self._const * self._saa[None]
        self._cya_b = self._cya.T @ self._onehot                    # (no, B)
        self._saa_b = self._saa @ self._onehot                      # (B,)
        self.noise = None
        self.sigma = None
        self.inflation = None

    def bounds(self):
        pr, nom = self.priors, self.nominal
        lo = np.array([np.log(nom.period_s / pr.period_factor), pr.damping_range[0],
                       np.log(nom.gain / pr.gain_factor)])
        hi = np.array([np.log(nom.period_s * pr.period_factor), pr.damping_range[1],
                       np.log(nom.gain * pr.gain_factor)])
        return lo, hi

    def _factors(self, theta):
        """(W, no) gain and normalisation factor and (W, F) ``1 / D(s; T, h)``."""
        theta = np.atleast_2d(theta)
        w0 = (2 * np.pi / np.exp(theta[:, 0]))[:, None]
        h = theta[:, 1][:, None]
        inv = 1.0 / (self._s * self._s + 2.0 * h * w0 * self._s + w0 * w0)
        d_sn = np.abs(self._sn[None] ** 2 + 2.0 * h * w0 * self._sn[None] + w0 * w0)  # (W, no)
        amp = np.exp(theta[:, 2])[:, None] / self._g_nom[None] * d_sn / self._dn_norm[None]
        return amp, inv

    def ratio(self, theta):
        """Element response over each output's deconvolution response,
        ``rho_c / base_c`` (``TwoPoleFamily.ratio`` of each output), shape
        (W, n_out, F)."""
        amp, inv = self._factors(theta)
        return amp[:, :, None] * self._const[None] * inv[:, None, :]

    def mu(self, theta):
        """Model transfer ``m_c rho_c / base_c``, shape (W, n_out, F)."""
        return self.coef[None, :, None] * self.ratio(theta)

    def residual(self, theta):
        """Band residuals ``R_b,c``, shape (W, B, n_out)."""
        amp, inv = self._factors(theta)
        model = np.add.reduceat(self._kernel[None] * inv[:, None, :], self._starts, axis=2)
        r = self._cya_b[None] - amp[:, :, None] * model
        return r.transpose(0, 2, 1)

    def log_prior(self, theta):
        theta = np.atleast_2d(theta)
        lo, hi = self.bounds()
        ok = np.all((theta > lo) & (theta < hi), axis=1)
        return np.where(ok, 0.0, -np.inf)

    def log_likelihood(self, theta):
        r = self.residual(theta)
        return -np.einsum("wbi,bij,wbj->w", r.conj(), self.noise, r).real

    def log_prob(self, theta):
        """Vectorised log posterior: theta (W, 3) -> (W,)."""
        theta = np.atleast_2d(theta)
        lp = self.log_prior(theta)
        out = np.full(theta.shape[0], -np.inf)
        ok = np.isfinite(lp)
        if ok.any():
            out[ok] = lp[ok] + self.log_likelihood(theta[ok])
        return out

    def whitened_residual(self, theta, chol):
        r = self.residual(theta)[0]                                  # (B, no)
        z = np.einsum("bji,bj->bi", chol.conj(), r)
        return np.concatenate([z.real.ravel(), z.imag.ravel()])

    def estimate_noise(self, theta):
        """Plug-in noise model at ``theta``: per-band ``Sigma_b`` and inflation
        ``c_b`` (see module docstring); sets ``self.noise`` (B, no, no)."""
        sp = self.spectra
        no = sp.n_u
        mu = self.mu(theta)[0].T                                     # (F, no)
        cya, saa = self._cya, self._saa
        e = (self._cyy - cya[:, :, None] * mu.conj()[:, None, :]
             - mu[:, :, None] * cya.conj()[:, None, :]
             + saa[:, None, None] * mu[:, :, None] * mu.conj()[:, None, :])
        n_bins = sp.bins_per_band * sp.n_segments
        sigma = np.einsum("fb,fij->bij", self._onehot, e) / n_bins[:, None, None]
        sigma = 0.5 * (sigma + sigma.conj().transpose(0, 2, 1))
        s_inv = np.linalg.inv(sigma)
        mu_b = (mu * saa[:, None]).T @ self._onehot / self._saa_b       # (no, B)
        seg = sp.per_segment                                          # (K, B, n, n)
        r_k = seg[:, :, :no, no] - mu_b.T[None] * seg[:, :, no, no][:, :, None]
        q0 = np.einsum("kbi,bij,kbj->b", r_k.conj(), s_inv, r_k).real
        adj = np.flatnonzero(np.diff(sp.segment_starts) < sp.nperseg)
        q1 = np.einsum("kbi,bij,kbj->b", r_k[adj + 1].conj(), s_inv, r_k[adj]).real
        raw = (q0 + 2.0 * q1) / (no * self._saa_b)
        pooled = raw.mean()
        wgt = sp.n_segments * no
        c = (wgt * raw + INFLATION_SHRINK * pooled) / (wgt + INFLATION_SHRINK)
        c = np.maximum(c, 1e-3 * pooled)
        self.sigma, self.inflation = sigma, c
        self.noise = s_inv / (c * self._saa_b)[:, None, None]
        return self.noise

    def misfit(self, theta):
        """Per output, the mean over bands of ``|R_b,c|^2`` over its expected
        value: about 1 where the model (and the geometry) fits."""
        r = self.residual(theta)[0]
        var = np.einsum("bii->bi", self.sigma).real * (self.inflation * self._saa_b)[:, None]
        return np.mean(np.abs(r) ** 2 / var, axis=0)

    def apparent_coefficients(self, theta):
        """Least-squares ``m_c`` per output given the element response at
        ``theta``: equals the geometry's ``M[n, c]`` when the geometry is right."""
        rho = self.ratio(theta)[0]
        num = np.sum(rho.conj() * self._cya.T, axis=1)
        den = np.sum(np.abs(rho) ** 2 * self._saa[None], axis=1)
        return num / den


def _start(model):
    """Nominal period and damping, and the least-squares scale of the nominal
    transfer to the data (its sign tells whether the geometry's polarity holds)."""
    nom = model.nominal
    theta = np.array([np.log(nom.period_s), nom.damping, np.log(nom.gain)])
    mu = model.mu(theta)[0]
    num = np.sum((mu.conj() * model._cya.T).real)
    den = np.sum(np.abs(mu) ** 2 * model._saa[None])
    return theta, num / den


def least_squares_run(model, theta0):
    """Weighted least squares with the noise model re-estimated twice; returns
    ``(theta, covariance (2 J^T J)^-1)`` like :func:`bayescal.fit.least_squares_fit`."""
    lo, hi = model.bounds()
    theta = np.clip(np.asarray(theta0, float), lo + 1e-9, hi - 1e-9)
    for _ in range(3):
        model.estimate_noise(theta)
        chol = np.linalg.cholesky(model.noise)
        res = least_squares(model.whitened_residual, theta, args=(chol,), bounds=(lo, hi),
                            x_scale="jac", method="trf", xtol=1e-12, ftol=1e-12, gtol=1e-12)
        theta = res.x
    model.estimate_noise(theta)
    chol = np.linalg.cholesky(model.noise)
    res = least_squares(model.whitened_residual, theta, args=(chol,), bounds=(lo, hi),
                        x_scale="jac", method="trf", max_nfev=1)
    try:
        cov = np.linalg.inv(2.0 * res.jac.T @ res.jac)
    except np.linalg.LinAlgError as exc:
        raise FitError("the least-squares point is degenerate (singular information)") from exc
    return theta, 0.5 * (cov + cov.T)


@dataclass
class ElementFit:
    """Posterior of one element from one run (possibly Z only)."""

    element: str
    outputs: list
    samples: np.ndarray          # (N, 3) period_s, damping, gain
    theta_ls: np.ndarray
    cov: np.ndarray
    convergence: dict
    misfit: dict
    apparent: dict
    inflation: np.ndarray
    band_hz: tuple
    model: RunModel = field(repr=False, default=None)

    def summary(self):
        out = {p: interval_summary(self.samples[:, j]) for j, p in enumerate(PARAMS)}
        out["outputs_used"] = self.outputs
        out["misfit"] = self.misfit
        out["apparent_coefficient"] = self.apparent
        out["convergence"] = self.convergence
        return out


def fit_run(run, m, coil_constant, band, nperseg=None, seed=0, progress=False,
            priors=Priors(), **sample_kw):
    """Posterior over one element's (period, damping, gain) from one run."""
    coef = run.coefficients(m)
    if np.all(np.abs(coef) < 1e-6):
        raise InputError(f"{run.source}: the outputs {run.axes} do not see element "
                         f"{run.element} in this geometry")
    nominal = run.families[-1]
    sp = run_spectra(run, coil_constant, band, nperseg)
    model = RunModel(sp, coef, run.families, nominal, priors)
    # start from the Z output when there is one: every element shows in Z with
    # the same sign in the built-in geometries, so a wrong X/Y sign convention
    # shows up as a misfit and a Z-only disagreement rather than a failed start
    iz = run.axes.index("Z") if "Z" in run.axes else None
    start_model = model if iz is None else RunModel(sp.select([iz]), coef[[iz]],
                                                    [run.families[iz]], nominal, priors)
    theta0, scale = _start(start_model)
    if not scale > 0:
        raise FitError(f"{run.source}: the outputs respond to the coil of {run.element} with "
                       "the opposite sign to the geometry: check the coil wiring, the output "
                       "polarity or the sensor matrix")
    theta0[2] += np.log(scale)
    lo, hi = model.bounds()
    if not lo[2] < theta0[2] < hi[2]:
        raise FitError(f"{run.source}: element {run.element}'s gain comes out "
                       f"{np.exp(theta0[2]):.4g}, more than {priors.gain_factor:g}x from "
                       f"nominal {nominal.gain:.4g}: check --coil-constant")
    theta, _ = least_squares_run(model, theta0)
    # second pass: deconvolve by the fitted response (see module docstring)
    t_ls = theta.copy()

    def base(f):
        return np.stack([fam.ratio(f, np.exp(t_ls[0]), t_ls[1], np.exp(t_ls[2]))[0]
                         for fam in run.families])

    sp = run_spectra(run, coil_constant, band, nperseg, base=base)
    model = RunModel(sp, coef, run.families, nominal, priors, base=base(sp.freqs))
    theta, cov = least_squares_run(model, theta)
    chain = sample(model, theta, cov, seed=seed, progress=progress, **sample_kw)
    s = chain.samples
    phys = np.column_stack([np.exp(s[:, 0]), s[:, 1], np.exp(s[:, 2])])
    med = np.median(s, axis=0)
    app = model.apparent_coefficients(med)
    conv = {"tau_max": float(chain.tau.max()), "ess_min": float(chain.ess.min()),
            "rhat_max": float(chain.rhat.max()), "n_steps": int(chain.n_steps),
            "n_walkers": int(chain.n_walkers), "acceptance": float(chain.acceptance),
            "converged": bool(chain.converged)}
    return ElementFit(
        element=run.element, outputs=list(run.axes), samples=phys, theta_ls=theta, cov=cov,
        convergence=conv, misfit=dict(zip(run.axes, model.misfit(med).tolist())),
        apparent={a: {"estimate": float(v.real), "expected": float(c), "imag": float(v.imag)}
                  for a, v, c in zip(run.axes, app, coef)},
        inflation=model.inflation, band_hz=(float(sp.band_edges[0]), float(sp.band_edges[-1])),
        model=model)


# --- derived XYZ responses ---------------------------------------------------

def equivalent_two_pole(target, family, freqs, start, iterations=12):
    """Fit ``family.ratio(freqs, T, h, G)`` to complex ``target`` (N, F) for
    every row at once (Gauss-Newton on the relative error); returns
    ``(params (N, 3) period_s, damping, gain; rms relative misfit (N,))``."""
    p = np.column_stack([np.log(start[:, 0]), start[:, 1], np.log(start[:, 2])])

    def res(q):
        r = family.ratio(freqs, np.exp(q[:, 0]), q[:, 1], np.exp(q[:, 2])) / target - 1.0
        return np.concatenate([r.real, r.imag], axis=1)

    steps = np.array([1e-6, 1e-6, 1e-6])
    for _ in range(iterations):
        r0 = res(p)
        jac = np.stack([(res(p + np.eye(3)[i] * steps[i]) - r0) / steps[i] for i in range(3)],
                       axis=2)                                       # (N, 2F, 3)
        jtj = np.einsum("nfi,nfj->nij", jac, jac)
        jtr = np.einsum("nfi,nf->ni", jac, r0)
        p = p - np.linalg.solve(jtj + 1e-12 * np.eye(3), jtr[..., None])[..., 0]
    rms = np.sqrt(np.mean(res(p) ** 2, axis=1) * 2)
    return np.column_stack([np.exp(p[:, 0]), p[:, 1], np.exp(p[:, 2])]), rms


def element_ratios(samples, family, freqs):
    """Element responses over the nominal, (N, 3, F), from joint samples
    (N, 3 elements, 3 params)."""
    return np.stack([family.ratio(freqs, samples[:, j, 0], samples[:, j, 1], samples[:, j, 2])
                     for j in range(3)], axis=1)


def derive_xyz(joint, m, family, freqs):
    """XYZ responses implied by joint element samples ``joint`` (N, 3, 3).

    Returns a dict: ``ratio`` (N, 3, 3, F) of ``M^T diag(k) M`` over the
    nominal response; ``equivalent`` (N, 3, 3) two-pole period, damping, gain
    per XYZ axis and ``equivalent_misfit`` (N, 3); ``gain_at_norm`` (N, 3) the
    diagonal's modulus at the normalisation frequency times the nominal gain;
    ``cross_talk`` (N,) and ``cross_talk_pair`` (N,).
    """
    k = element_ratios(joint, family, freqs)
    t = response_matrix(k, m)
    diag = np.einsum("nllf->nlf", t)
    w = m * m                                                    # (3 elements, 3 axes)
    eq, mis = [], []
    for ax in range(3):
        start = np.einsum("j,njp->np", w[:, ax], joint)
        pars, rms = equivalent_two_pole(diag[:, ax], family, freqs, start)
        eq.append(pars)
        mis.append(rms)
    kn = element_ratios(joint, family, np.array([family.norm_freq]))
    g_norm = np.abs(np.einsum("jl,njf->nlf", w, kn)[..., 0]) * family.gain
    ct, pair = cross_talk(t)
    return {"ratio": t, "equivalent": np.stack(eq, axis=1), "equivalent_misfit":
            np.stack(mis, axis=1), "gain_at_norm": g_norm, "cross_talk": ct,
            "cross_talk_pair": pair}


# --- the whole calibration ---------------------------------------------------

def agreement(fit_all, fit_z):
    """Z-only vs all-output consistency per element parameter: the difference
    of medians over ``sqrt(sd_z^2 - sd_all^2)`` (the all-output estimate uses
    the Z data too; floored at 0.2 sd_z)."""
    out = {}
    for j, p in enumerate(PARAMS):
        a, z = fit_all.samples[:, j], fit_z.samples[:, j]
        sa, sz = np.std(a), np.std(z)
        den = np.sqrt(max(sz ** 2 - sa ** 2, (0.2 * sz) ** 2))
        out[p] = {"difference": float(np.median(a) - np.median(z)),
                  "z": float((np.median(a) - np.median(z)) / den)}
    return out


@dataclass
class UVWResult:
    """Everything one UVW calibration produces (see :meth:`summary`)."""

    matrix: np.ndarray
    matrix_source: str
    fits: dict                    # element -> ElementFit (all outputs, or Z only)
    z_fits: dict                  # element -> ElementFit from Z only (default mode)
    joint: np.ndarray             # (N, 3, 3) paired element samples
    xyz: dict                     # from derive_xyz
    freqs: np.ndarray
    family: TwoPoleFamily
    relative_gain: bool
    mode: str
    meta: dict = field(default_factory=dict)

    def _gain_scale(self, joint):
        """Per-sample divisor of gains: 1, or the elements' geometric mean."""
        if not self.relative_gain:
            return np.ones(joint.shape[0])
        return np.exp(np.mean(np.log(joint[:, :, 2]), axis=1))

    def summary(self):
        """The ``uvw.json`` content (schema ``bayescal.uvw/1``)."""
        scale = self._gain_scale(self.joint)
        elements = {}
        for j, e in enumerate(ELEMENTS):
            entry = self.fits[e].summary()
            entry["gain"] = interval_summary(self.joint[:, j, 2] / scale)
            elements[e] = entry
        xyz = {}
        for ax, name in enumerate(XYZ):
            eq = self.xyz["equivalent"][:, ax]
            xyz[name] = {"period_s": interval_summary(eq[:, 0]),
                         "damping": interval_summary(eq[:, 1]),
                         "gain": interval_summary(eq[:, 2] / scale),
                         "gain_at_norm_freq": interval_summary(self.xyz["gain_at_norm"][:, ax]
                                                               / scale),
                         "two_pole_misfit_max": float(np.max(self.xyz["equivalent_misfit"][:, ax]))}
        pairs = ("X-Y", "X-Z", "Y-Z")
        out = {"schema": SCHEMA, "mode": self.mode, "elements": elements, "xyz": xyz,
               "cross_talk_max": interval_summary(self.xyz["cross_talk"]),
               "cross_talk_max_pair": pairs[int(np.bincount(self.xyz["cross_talk_pair"],
                                                            minlength=3).argmax())],
               "gain_units": ("relative: each gain over the geometric mean of the three "
                              "element gains (no --coil-constant given)") if self.relative_gain
               else f"{self.family.gain_units} (first stage), at {self.family.norm_freq:g} Hz",
               "nominal": {"period_s": self.family.period_s, "damping": self.family.damping,
                           "gain": self.family.gain},
               "geometry": {"matrix_uvw_rows_xyz_columns": self.matrix.tolist(),
                            "source": self.matrix_source}}
        out["geometry"]["apparent_coefficients"] = {e: self.fits[e].apparent for e in ELEMENTS}
        dev = [abs(v["estimate"] - v["expected"]) for e in ELEMENTS
               for v in self.fits[e].apparent.values()]
        out["geometry"]["max_abs_deviation"] = float(max(dev))
        if self.z_fits:
            zs = {e: self.z_fits[e].summary() for e in ELEMENTS}
            if self.relative_gain:
                zj = _pair([self.z_fits[e] for e in ELEMENTS], self.joint.shape[0],
                           np.random.default_rng(0))
                for j, e in enumerate(ELEMENTS):
                    zs[e]["gain"] = interval_summary(zj[:, j, 2] / self._gain_scale(zj))
            ag = {e: agreement(self.fits[e], self.z_fits[e]) for e in ELEMENTS}
            worst = max(abs(v["z"]) for a in ag.values() for v in a.values())
            out["z_only"] = zs
            out["agreement"] = {"elements": ag, "max_abs_z": worst,
                                "consistent": bool(worst < AGREEMENT_Z),
                                "note": ("Z-only and all-output estimates agree" if worst
                                         < AGREEMENT_Z else
                                         "Z-only and all-output estimates disagree: evidence "
                                         "against the geometry (sensor matrix or output "
                                         "polarity); see geometry.apparent_coefficients")}
        out["band_hz"] = list(self.fits[ELEMENTS[0]].band_hz)
        out["meta"] = self.meta
        return out


def _pair(fits, n_max, rng):
    n = min(n_max, *(f.samples.shape[0] for f in fits))
    return np.stack([f.samples[rng.choice(f.samples.shape[0], n, replace=False)] for f in fits],
                    axis=1)


def calibrate_uvw(runs, m, coil_constant=None, band=None, z_only=False, seed=0, progress=False,
                  matrix_source="", nperseg=None, n_derived=2000, **sample_kw):
    """Posterior over the three elements from coil-by-coil runs.

    Parameters
    ----------
    runs : dict element ("U", "V", "W") -> :class:`CalRun`.
    m : UVW matrix (rows U, V, W over columns X, Y, Z).
    coil_constant : m/s^2 per input count, or None (gains then relative).
    band : (fmin, fmax) Hz; default ``(0.5 / T_nom, min(25 / T_nom, fs / 4))``.
    z_only : use only each run's Z output (the seed's procedure).
    """
    missing = [e for e in ELEMENTS if e not in runs]
    if missing:
        raise InputError(f"no calibration run for element(s) {', '.join(missing)}")
    fam = runs["U"].families[-1]
    if band is None:
        fs = min(r.fs for r in runs.values())
        band = (0.5 / fam.period_s, min(25.0 / fam.period_s, fs / 4))
    has_z = all("Z" in r.axes for r in runs.values())
    if z_only and not has_z:
        src = next(r.source for r in runs.values() if "Z" not in r.axes)
        raise InputError(f"{src}: --z-only needs a Z output in every run")
    relative = coil_constant is None
    c_eff = 1.0 if relative else float(coil_constant)
    if relative:
        c_eff = _relative_coil_constant(runs, m, band, nperseg, fam)
    fits, z_fits = {}, {}
    for i, e in enumerate(ELEMENTS):
        run = runs[e].select(["Z"]) if z_only else runs[e]
        fits[e] = fit_run(run, m, c_eff, band, nperseg, seed=seed + i, progress=progress,
                          **sample_kw)
        if not z_only and has_z and len(runs[e].axes) > 1:
            z_fits[e] = fit_run(runs[e].select(["Z"]), m, c_eff, band, nperseg,
                                seed=seed + 10 + i, progress=progress, **sample_kw)
    rng = np.random.default_rng(seed)
    joint = _pair([fits[e] for e in ELEMENTS], n_derived, rng)
    freqs = np.geomspace(band[0], band[1], 120)
    xyz = derive_xyz(joint, m, fam, freqs)
    mode = "z-only" if z_only else "all-outputs"
    meta = {"coil_constant": coil_constant, "coil_constant_used": c_eff,
            "runs": {e: {"source": r.source, "outputs": r.ids, "sampling_rate": r.fs,
                         "duration_s": r.data.shape[1] / r.fs} for e, r in runs.items()}}
    return UVWResult(matrix=np.asarray(m, float), matrix_source=matrix_source, fits=fits,
                     z_fits=z_fits if len(z_fits) == 3 else {}, joint=joint, xyz=xyz,
                     freqs=freqs, family=fam, relative_gain=relative, mode=mode, meta=meta)


def _relative_coil_constant(runs, m, band, nperseg, fam):
    """Without a coil constant: the one that puts the geometric mean of the
    three elements' start gains at the nominal gain."""
    logs = []
    for e in ELEMENTS:
        run = runs[e]
        sp = run_spectra(run, 1.0, band, nperseg)
        model = RunModel(sp, run.coefficients(m), run.families, run.families[-1])
        _, scale = _start(model)
        if not scale > 0:
            raise FitError(f"{run.source}: the outputs respond to the coil of {e} with the "
                           "opposite sign to the geometry")
        logs.append(np.log(scale))
    return float(np.exp(np.mean(logs)))
