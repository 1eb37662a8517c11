"""Time-domain likelihood of a calibration run whose input is not broadband
(a step or a sine), shared by :mod:`.step` and :mod:`.sine`.

The output is modelled sample by sample as

    x(t) = m(t; theta) + c0 + c1 t + n(t),

with ``m`` the response of the channel to the recorded input (computed by
:func:`Predictor`: FFT of the input over a zero-padded buffer, so the
convolution is linear, not circular), an offset and a linear drift
(nuisance, marginalised with a flat prior by projecting them out), and
``n`` autocorrelated noise modelled as a fractionally integrated
autoregression ARFIMA(p, d, 0), ``(1 - B)^d n`` an AR(p), estimated from the
data: the residual of the least-squares fit over the whole record (before,
during and after the step(s), or around the sine), ``d`` on the grid
``D_GRID`` and the order ``p`` (at most ``MAX_AR_ORDER``) chosen together by
BIC (:func:`noise_fit`), the fit and the noise re-estimated in turn. The
fractional difference lets the model follow a power-law spectrum
(``f^-2d`` at low frequency) down to the record's lowest frequencies, which
a low-order AR alone, fitted where most samples' variance is, does not:
with self-noise as 1/f in acceleration the AR alone put 2-7 times too little
power below 2 mHz and twice too much at 5-50 mHz, so a step's period and
damping came out 1.5 times too narrow (docs/validation/coil.md). With the
whitening filter ``L`` (the AR prediction-error filter times the fractional
difference, innovation variance ``s2``) the log likelihood is

    log L(theta) = -|| P (L x - L m(theta)) ||^2 / (2 s2),

``P`` the projection orthogonal to the whitened nuisance columns, the first
``p`` samples (whose whitening needs samples before the record) and any
settling time left out. A model may set a fixed prefilter ``Q``
(:meth:`TimeModel.set_prefilter`): the AR model is then fitted to ``Q r``
and the whitening is ``L Q`` (the step kind takes the output back to
equivalent acceleration, where an all-pole model can describe the noise). Whitening the model is one product with the AR
filter's frequency response inside the same FFT. The posterior is sampled by
:func:`bayescal.core.sampling.mcmc.sample` (the sampler and convergence rule of
every bayescal fit), started from the least-squares point and its Laplace
covariance.

Adequacy: the standardised innovations at the posterior median should be
white with unit variance; ``adequacy`` gives their mean square and the
Ljung-Box p-value of their first ``LB_LAGS`` autocorrelations.
"""
from __future__ import annotations

import numpy as np
from scipy.fft import irfft, next_fast_len, rfft, rfftfreq
from scipy.signal import fftconvolve, lfilter
from scipy.stats import chi2

from ..core.fit import refine
from ..errors import InputError
from .bounded import BoundedPosterior

#: Largest autoregression order tried for the noise.
MAX_AR_ORDER = 20
#: Fractional differencing orders ``d`` tried for the noise (0: an AR alone;
#: 0.5: 1/f noise made white; 1: a random walk).
D_GRID = np.round(np.arange(0.0, 1.0001, 0.05), 2)
#: Lags of the Ljung-Box whiteness check of the innovations.
LB_LAGS = 20
#: Zero padding after the record, in decay times ``1 / (h w0)`` of the
#: nominal pendulum: the response to the record's last samples has decayed
#: to ``e^-25`` before it could wrap round to the start of the buffer.
PAD_DECAYS = 25.0


def ar_fit(r, max_order=MAX_AR_ORDER):
    """Autoregression of ``r`` by least squares, order by BIC.

    Returns ``(a, s2)``: ``r_t = sum_k a_k r_{t-k} + e_t``, ``var e = s2``.
    """
    return _ar_bic(r, max_order)[1:]


def _ar_bic(r, max_order, extra=0):
    """``(bic, a, s2)`` of the BIC-best autoregression of ``r`` (the order
    0 included; ``extra`` parameters added to every order's count). The
    first ``min(max_order, n // 20)`` samples are conditioned on, whatever
    the order, so the BIC of two series of one length compare."""
    r = np.asarray(r, float) - np.mean(r)
    n = r.size
    p_max = min(max_order, n // 20)
    y = r[p_max:]
    s2 = float(np.mean(y * y))
    best = (y.size * np.log(s2) + extra * np.log(y.size), np.zeros(0), s2)
    if p_max == 0:
        return best
    lagged = np.column_stack([r[p_max - k:n - k] for k in range(1, p_max + 1)])
    for p in range(1, p_max + 1):
        a, *_ = np.linalg.lstsq(lagged[:, :p], y, rcond=None)
        e = y - lagged[:, :p] @ a
        s2 = float(np.mean(e * e))
        bic = y.size * np.log(s2) + (p + extra) * np.log(y.size)
        if bic < best[0]:
            best = (bic, a, s2)
    return best


def fractional_difference(d, n):
    """The first ``n`` coefficients of ``(1 - B)^d``: ``pi_0 = 1``,
    ``pi_k = pi_{k-1} (k - 1 - d) / k`` (Hosking 1981)."""
    k = np.arange(1, n)
    return np.cumprod(np.r_[1.0, (k - 1 - d) / k])


def fir(b, y):
    """``y`` (n,) or (n, m) through the FIR filter ``b`` from rest, first
    ``n`` samples (scipy's ``lfilter`` for short filters, FFT convolution
    for long ones)."""
    if len(b) <= 64:
        return lfilter(b, 1.0, y, axis=0)
    b = np.asarray(b, float).reshape((-1,) + (1,) * (np.ndim(y) - 1))
    return fftconvolve(y, b, axes=0)[:len(y)]


def noise_fit(r, max_order=MAX_AR_ORDER, d_grid=D_GRID, skip=0):
    """ARFIMA(p, d, 0) of ``r[skip:]``: ``d`` from ``d_grid`` and ``p``
    together by BIC (the fractional difference applied from rest is unit
    lower triangular, so each ``d``'s innovations give the likelihood of
    ``r`` itself; ``d > 0`` counts as one parameter). The fractional
    difference runs from ``r``'s first sample and is cut at ``skip``, as the
    likelihood whitens (:meth:`TimeModel.set_noise`): the first ``skip``
    samples are its past, not left out as if the noise had started from
    rest there. Returns ``(a, s2, d)``."""
    r = np.asarray(r, float)
    r = r - np.mean(r[skip:])
    best = None
    for d in d_grid:
        series = r if d == 0 else fir(fractional_difference(d, r.size), r)
        bic, a, s2 = _ar_bic(series[skip:], max_order, extra=int(d != 0))
        if best is None or bic < best[0]:
            best = (bic, a, s2, float(d))
    return best[1:]


def prediction_error_filter(a):
    """FIR coefficients ``[1, -a_1, ..., -a_p]`` of the AR whitening filter."""
    return np.r_[1.0, -np.asarray(a, float)]


class Predictor:
    """Response of a channel to a recorded input, on a zero-padded FFT grid.

    ``transfer(f)`` (F,) is the nominal input-to-output transfer (counts per
    input count); :meth:`__call__` multiplies it by ``ratio`` (W, F) (the
    fitted over the nominal response) and by ``weight`` (F,) (e.g. the
    whitening filter) and returns the first ``n`` samples, shape (W, n).
    """

    def __init__(self, u, fs, transfer, pad, span=0):
        self.n = u.size
        # after the record the input is held at its last value and brought to
        # zero smoothly (half a Hann window, ``pad // 4`` samples), then zeros:
        # an abrupt end would ring back into the record (band-limited signal)
        taper = max(int(pad) // 4, 64)
        tail = u[-1] * 0.5 * (1 + np.cos(np.pi * np.arange(1, taper + 1) / taper))
        # ``span``: the length of a whitening filter applied as a ``weight``;
        # the buffer holds it too, so its product is a linear (not circular)
        # convolution over the record
        self.nfft = next_fast_len(self.n + taper + int(pad) + int(span), real=True)
        self.freqs = rfftfreq(self.nfft, 1.0 / fs)
        self.spectrum = rfft(np.r_[u, tail], n=self.nfft) * transfer(self.freqs)

    def __call__(self, ratio, weight=None):
        x = self.spectrum if weight is None else self.spectrum * weight
        return irfft(np.atleast_2d(ratio) * x[None], n=self.nfft, axis=1)[:, :self.n]


def coil_transfer(run, coil_constant):
    """Nominal transfer from input counts to output counts of a one-output
    run: ``H_nom(f) C / (2 pi i f)`` (zero at 0 Hz: the velocity response
    has zeros at the origin)."""
    def transfer(f):
        f = np.asarray(f, float)
        h = np.zeros(f.size, complex)
        pos = f > 0
        h[pos] = run.nominal_response(f[pos])[0] * coil_constant / (2j * np.pi * f[pos])
        return h
    return transfer


def padding(family, fs):
    """Samples of zero padding after a record (see ``PAD_DECAYS``)."""
    decay = family.period_s / (2 * np.pi * max(family.damping, 0.05))
    return int(PAD_DECAYS * decay * fs) + 64


def checked_arrays(run):
    """Output and input of a one-output run as float arrays; gaps refused."""
    x, u = run.data[0], run.input
    if not (np.all(np.isfinite(x)) and np.all(np.isfinite(u))):
        raise InputError(f"{run.source}: the run has gaps; step and sine calibration need a "
                         "continuous record (cut it at the gap)")
    return x.astype(float), u.astype(float)


class TimeModel(BoundedPosterior):
    """Posterior of ``theta`` from a time series (see module docstring).

    Subclasses set ``names``, ``ndim``, ``bounds()`` and
    ``predict(theta, weight)`` -> (W, n) model output (through the FFT
    weight ``weight``, the whitening filter's response, when given).
    """

    #: ``-log L`` is half the innovations' squared norm.
    LIKELIHOOD_SCALE = 0.5

    def __init__(self, x, fs, predictor, skip=0):
        self.x = np.asarray(x, float)
        self.fs = fs
        self.predictor = predictor
        self.skip = int(skip)
        t = np.arange(self.x.size) / fs
        self.nuisance = np.column_stack([np.ones_like(t), t - t.mean()])
        self.set_noise(np.zeros(0), 1.0, 0.0)

    # --- noise ---------------------------------------------------------------
    #: Fractional orders ``d`` the noise model chooses from.
    d_grid = D_GRID
    #: Fixed IIR prefilter ``(b, a)`` applied before the AR whitening (the
    #: identity by default; :meth:`set_prefilter`).
    prefilter = (np.ones(1), np.ones(1))

    def set_prefilter(self, b, a):
        """Whiten by the AR filter *after* the fixed filter ``b(z) / a(z)``
        (leading coefficients 1, so the likelihood's Jacobian is 1). With
        ``a = [1, -1]`` (an integrator) the integration constant joins the
        nuisance (offset, drift) and is projected out."""
        self.prefilter = (np.asarray(b, float), np.asarray(a, float))
        self.set_noise(self.ar, self.s2, self.d)

    def _pre(self, y):
        b, a = self.prefilter
        return lfilter(b, a, y, axis=0)

    def set_noise(self, a, s2, d=0.0):
        """Use AR coefficients ``a``, innovation variance ``s2`` and
        fractional differencing order ``d``."""
        self.ar, self.s2, self.d = np.asarray(a, float), float(s2), float(d)
        b = prediction_error_filter(self.ar)
        if self.d:
            b = np.convolve(b, fractional_difference(self.d, self.x.size))[:self.x.size]
        zinv = np.exp(-2j * np.pi * self.predictor.freqs / self.fs)
        pb, pa = self.prefilter
        with np.errstate(divide="ignore", invalid="ignore"):
            w = (rfft(b, n=self.predictor.nfft) * np.polyval(pb[::-1], zinv)
                 / np.polyval(pa[::-1], zinv))
        self._weight = np.where(np.isfinite(w), w, 0.0)
        self._keep = slice(max(self.skip, self.ar.size), None)
        xw = fir(b, self._pre(self.x))[self._keep]
        cols = self._pre(self.nuisance)
        if pa.size > 1:
            cols = np.column_stack([cols, np.ones(self.x.size)])
        nw = fir(b, cols)[self._keep]
        self._q, _ = np.linalg.qr(nw)
        self._xw = xw - self._q @ (self._q.T @ xw)

    def raw_residual(self, theta):
        """``x - m(theta)`` with offset and drift removed by least squares."""
        r = self.x - self.predict(theta)[0]
        c, *_ = np.linalg.lstsq(self.nuisance, r, rcond=None)
        return r - self.nuisance @ c

    def estimate_noise(self, theta):
        """Noise model from the residual at ``theta`` (:meth:`fit_noise`)."""
        self.fit_noise(self.raw_residual(theta))

    def fit_noise(self, r):
        """Set the noise model to :func:`noise_fit` of the residual ``r``
        after the prefilter and after ``skip``, both filters (the prefilter
        and the fractional difference) run over the whole record as the
        likelihood runs them."""
        self.set_noise(*noise_fit(self._pre(r), d_grid=self.d_grid, skip=self.skip))

    # --- likelihood ----------------------------------------------------------
    def innovations(self, theta):
        """Standardised whitened residuals, (W, n_kept)."""
        mw = self.predict(theta, self._weight)[:, self._keep]
        mw = mw - (mw @ self._q) @ self._q.T
        return (self._xw[None] - mw) / np.sqrt(self.s2)

    def likelihood_residual(self, theta):
        """The standardised innovations at one ``theta`` (ndim,)."""
        return self.innovations(np.asarray(theta, float)[None])[0]

    def log_likelihood(self, theta):
        """``-|innovations|^2 / 2``, theta (W, ndim) -> (W,)."""
        e = self.innovations(theta)
        return -0.5 * np.sum(e * e, axis=1)

    def report_series(self, theta):
        """The time series a report draws at ``theta``: the model output
        ``series_model``, the residual ``series_residual`` (offset and drift
        removed), the standardised ``innovations``, the sampling rate
        ``series_fs`` and the samples left out at the start ``series_skip``."""
        return {"series_model": self.predict(theta)[0], "series_residual": self.raw_residual(theta),
                "innovations": self.innovations(theta)[0], "series_fs": self.fs,
                "series_skip": self.skip}

    def adequacy(self, theta):
        """Mean square of the standardised innovations (about 1 when the
        model fits), the Ljung-Box p-value of their whiteness, the AR order."""
        e = self.innovations(theta)[0]
        e0 = e - e.mean()
        n = e0.size
        acf = np.array([e0[k:] @ e0[:-k] for k in range(1, LB_LAGS + 1)]) / (e0 @ e0)
        q = n * (n + 2) * np.sum(acf ** 2 / (n - np.arange(1, LB_LAGS + 1)))
        return {"misfit": float(np.mean(e * e)), "n_samples": int(n),
                "p_value": float(chi2.sf(q, LB_LAGS)),
                "test": f"Ljung-Box on the innovations, {LB_LAGS} lags",
                "ar_order": int(self.ar.size), "fractional_d": self.d}


def least_squares_time(model, theta0, passes=3):
    """Least squares on the whitened residual (and the pendulum prior's rows
    of a model of the pendulum pair), the noise model re-estimated after
    each pass, in two stages: an AR alone (``d = 0``) from ``theta0``; then
    ``d`` chosen (from the model's ``d_grid``, BIC) at that point and held
    while the AR is re-estimated. (With ``d`` free in every pass, a misfit of the
    response left by an early pass is taken for red noise, which then
    hides it: white-noise runs settled 3 sd off.) Returns ``(theta,
    Laplace covariance (J^T J)^-1)``; the model keeps ``d_grid = (d,)``."""
    lo, hi = model.bounds()

    def fun(t):
        return np.concatenate([model.innovations(t[None])[0], model.prior_residual(t)])

    grid, model.d_grid = model.d_grid, (0.0,)
    try:
        theta, _ = refine(fun, theta0, lo, hi, model.estimate_noise, passes, method="trf",
                          scale=1.0, x_scale="jac")
    finally:
        model.d_grid = grid
    model.estimate_noise(theta)
    model.d_grid = (model.d,)
    return refine(fun, theta, lo, hi, model.estimate_noise, passes, method="trf", scale=1.0,
                  reestimate_first=False, x_scale="jac")
