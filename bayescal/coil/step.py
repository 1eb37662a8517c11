"""Step calibration of one output channel: the response to one or more steps
of coil current (an acceleration step ``C du``), fitted in the time domain
(:mod:`.timedomain`: fractionally integrated AR noise estimated from the residual after
:func:`acceleration_prefilter`, offset and drift marginalised) with the
long-period pair and the gain free (:class:`bayescal.coil.hf.PZSpec`
``fit="lp"``): period and damping, as the
USGS ASL Sensor Test Suite reports them from a step, and the gain.

The input may hold any sequence of steps (on, off, several): the model is
the nominal response with the free parts replaced, applied to the recorded
input (its plateaus freed of the input channel's own noise,
:func:`bayescal.coil.drive.step_drive`) through a zero-padded FFT. The record is assumed to start with the
input at rest for long enough that the sensor has settled (the input's
first level is taken as its rest level); the samples before the first step
are conditioned on (whitened, then left out of the likelihood): the noise
model's fractional difference starts from rest, and the record's missing
past leaves a slowly decaying transient at its start.
"""
from __future__ import annotations

import numpy as np

from scipy.fft import irfft

from ..core.priors import Priors
from ..core.response import pendulum_coefficients, pendulum_denominator
from ..core.sampling import sample
from ..core.threads import single_threaded_blas
from ..errors import InputError
from .drive import step_drive
from .hf import PZSpec, scale_start
from .result import CalFit
from .timedomain import (Predictor, TimeModel, checked_arrays, coil_transfer,
                         least_squares_time, padding)


class StepModel(TimeModel):
    """:class:`TimeModel` with the response of a :class:`PZSpec`; the AR
    noise model is fitted after :func:`acceleration_prefilter`."""

    def __init__(self, x, fs, predictor, spec, skip=0):
        self.spec = spec
        self.names = spec.names
        self.ndim = spec.ndim
        self.pendulum_index = spec.pendulum_index
        self.priors = spec.priors
        self._bounds = spec.bounds()
        if spec.items or not spec.has_lp:
            raise ValueError("StepModel fits the long-period pair and gain only")
        fam = spec.family
        self._s = 2j * np.pi * predictor.freqs
        # D = s^2 + c1 s + c0 with c0 = c0_rel w0n^2, c1 = c1_rel 2 h_n w0n
        c1, c0 = pendulum_coefficients(fam.period_s, fam.damping)
        self._c_nom = np.array([c0, c1])
        self._d_nom = pendulum_denominator(self._s, c1, c0)
        self._sn = 2j * np.pi * fam.norm_freq
        self._dn = abs(pendulum_denominator(self._sn, c1, c0)) * fam.gain
        self._cache = {}
        super().__init__(x, fs, predictor, skip)
        self.set_prefilter(*acceleration_prefilter(fam, fs))

    def set_noise(self, a, s2, d=0.0):
        self._cache = {}
        super().set_noise(a, s2, d)

    def bounds(self):
        return self._bounds

    def predict(self, theta, weight=None):
        """Model output (W, n): :meth:`PZSpec.ratio` (``fit="lp"``) written
        out with its per-frequency constants cached (the hot path)."""
        theta = np.atleast_2d(theta)
        key = "raw" if weight is None else "whitened"
        if key not in self._cache:
            x = self.predictor.spectrum if weight is None else self.predictor.spectrum * weight
            self._cache[key] = x * self._d_nom
        const = self._cache[key]
        b, c = theta[:, 1] * self._c_nom[1], theta[:, 0] * self._c_nom[0]
        amp = np.exp(theta[:, 2]) * np.abs(pendulum_denominator(self._sn, b, c)) / self._dn
        d = pendulum_denominator(self._s[None], b[:, None], c[:, None])
        spec = (amp[:, None] * const[None]) / d
        return irfft(spec, n=self.predictor.nfft, axis=1)[:, :self.predictor.n]


def acceleration_prefilter(family, fs):
    """``(b, a)`` of the filter that takes the output (counts) back to the
    equivalent ground acceleration through the nominal pendulum, in discrete
    time: its two poles ``exp(p / fs)`` become zeros, the zero at 0 Hz of
    the acceleration-to-output response an integrator ``1 / (1 - z^-1)``.

    Why: noise seen through the sensor (self-noise, ground noise) has a zero
    at 0 Hz in counts (the response's high-pass), which an autoregression,
    all poles, cannot represent; fitted to such noise it puts several times
    too much power below the pendulum's corner and too little just above it,
    where a step's information sits (docs/validation/coil.md, "Step runs"). In
    acceleration the noise has no zero (the digitizer's white noise becomes
    red, a pole at 0 Hz, which it can represent)."""
    w0 = 2 * np.pi / family.period_s
    h = family.damping
    poles = np.roots([1.0, 2 * h * w0, w0 * w0])
    b = np.real(np.poly(np.exp(poles / fs)))
    return b, np.array([1.0, -1.0])


def first_move(u):
    """Index of the input's first sample that differs from its first by
    more than half its range (``u.size`` if none)."""
    moved = np.flatnonzero(np.abs(u - u[0]) > 0.5 * np.ptp(u))
    return int(moved[0]) if moved.size else u.size


def rest_level(u):
    """The input's level before its first change: the median of the samples
    before it first moves by half its range."""
    return float(np.median(u[:max(first_move(u), 1)]))


#: Fewest samples after the first step: the noise model's autoregression
#: needs 20 samples per order (:func:`bayescal.coil.timedomain.ar_fit`).
MIN_SAMPLES_AFTER_STEP = 20


def _check_after_step(run, first, period_s):
    """Refuse a run whose record after the input's first step (sample
    ``first``) is shorter than the sensor's nominal natural period or than
    :data:`MIN_SAMPLES_AFTER_STEP` samples: :class:`InputError`."""
    n_after = run.input.size - first
    if n_after < max(MIN_SAMPLES_AFTER_STEP, period_s * run.fs):
        raise InputError(
            f"{run.source}: the input's first step comes {n_after / run.fs:.4g} s "
            f"({n_after} samples) before the record ends; a step's response needs at least "
            f"the sensor's natural period ({period_s:.4g} s) and {MIN_SAMPLES_AFTER_STEP} "
            "samples recorded after the step: record longer after it")


def _start(model, spec):
    """Nominal theta with the gain scaled by least squares (offset, drift free)."""
    theta = spec.nominal_theta()
    m = model.predict(theta)[0]
    design = np.column_stack([m, model.nuisance])
    coef, *_ = np.linalg.lstsq(design, model.x, rcond=None)
    return theta, coef[0]


def least_squares_step(run, coil_constant, priors=Priors()):
    """The step model of ``run`` (one output) at its least-squares point (the
    pendulum prior's rows included):
    ``(model, spec, theta, Laplace covariance)``; the noise model estimated
    there. The start of :func:`fit_step`'s sampler."""
    x, u = checked_arrays(run)
    u = u - rest_level(u)
    if not np.ptp(u) > 0:
        raise InputError(f"{run.source}: the input channel holds no step (it is constant)")
    u = step_drive(u)
    spec = PZSpec.from_response(run.responses[0], "lp", run.fs / 2, source=run.source,
                                priors=priors)
    _check_after_step(run, first_move(u), spec.family.period_s)
    pred = Predictor(u, run.fs, coil_transfer(run, coil_constant), padding(spec.family, run.fs),
                     span=u.size)     # the fractional difference's filter: the record's length
    # the samples before the first step are conditioned on (module docstring):
    # with 1/f noise the missing past's transient biased the period by 1 sd
    model = StepModel(x, run.fs, pred, spec, skip=max(first_move(u) - 1, 0))
    model.input = u
    theta0, scale = _start(model, spec)
    theta0 = scale_start(run, spec, theta0, scale)
    with single_threaded_blas():
        model.estimate_noise(theta0)
        theta, cov = least_squares_time(model, theta0)
    return model, spec, theta, cov


def fit_step(run, coil_constant, fit="lp", seed=0, progress=False, priors=Priors(),
             **sample_kw):
    """Posterior of period, damping and gain from a step run (``run``
    restricted to one output), under ``priors`` (the tolerances of period and
    damping). Returns a :class:`CalFit` of kind ``step``."""
    if len(run.axes) != 1:
        raise ValueError("fit_step takes a run with one output (CalRun.select)")
    if fit != "lp":
        raise InputError(f"{run.source}: --kind step fits the long-period pair and the gain "
                         f"only (--fit lp), not --fit {fit}")
    model, spec, theta, cov = least_squares_step(run, coil_constant, priors)
    with single_threaded_blas():
        chain = sample(model, theta, cov, seed=seed, progress=progress, **sample_kw)
    x, u = model.x, model.input
    dur = x.size / run.fs
    band = (1.0 / dur, 0.4 * run.fs)
    out = CalFit.from_chain("step", run, spec, model, chain, coil_constant, band)
    out.meta["band_note"] = "band_hz: the range the response curves are drawn over"
    out.meta["n_steps_in_input"] = int(np.sum(np.abs(np.diff(u)) > 0.5 * np.ptp(u)))
    return out
