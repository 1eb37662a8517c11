"""Sine calibration of one output channel: the response at the sine's
frequency ``f0`` (amplitude and phase), with its posterior.

The model is that of :mod:`.timedomain` with the nominal response's output
to the drive (the least-squares sine of the recorded input,
:func:`bayescal.coil.drive.sine_drive`), ``p(t)``, and its output to the
quadrature drive (the same sine a quarter period ahead,
:func:`quadrature_drive`), ``q(t)``, combined as

    m(t; theta) = Re(rho) p(t) + Im(rho) q(t),   rho = H(f0) / H_nom(f0) = A e^{i phi},

exact once the sine's switch-on transient has decayed. (Multiplying the
drive's spectrum by ``i`` gives the quadrature of a sine that fills the FFT
buffer periodically; the drive is cut to the record and zero-padded, and
``i`` times its spectrum is the Hilbert transform of the cut sine, whose
tails and low-frequency content are no sine: with red self-noise the
whitened fit leant on them and the amplitude came out 30-41 % low,
docs/validation/coil.md.)
``theta = (ln A, phi)``. The first ``SETTLE_DECAYS`` decay times of the
nominal pendulum are left out of the likelihood: there the model holds the
transient of a sine switched on at the record's start, which a record cut
from a running sine does not. The frequency is the input's periodogram peak
refined by least squares; an input that a single sine does not explain
(``MIN_SINE_FRACTION`` of its variance) is refused.

Reported: ``f0``, the amplitude ratio ``A`` and phase difference ``phi``
(degrees) against the nominal response, and the implied response
(counts per m/s, amplitude and phase) at ``f0``.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from scipy.optimize import minimize_scalar

from ..core.posterior import interval_summary
from ..core.sampling import sample
from ..errors import FitError, InputError
from ..core.threads import single_threaded_blas
from .drive import sine_drive, with_drive_error
from .result import SCHEMA
from .timedomain import (Predictor, TimeModel, checked_arrays, coil_transfer,
                         least_squares_time, padding)

#: Decay times ``1 / (h w0)`` of the nominal pendulum left out at the start.
SETTLE_DECAYS = 8.0
#: Fraction of the input's variance a single sine must explain.
MIN_SINE_FRACTION = 0.95


def sine_frequency(u, fs):
    """Frequency (Hz) of the sine in ``u`` and the fraction of its variance
    the best single sine explains."""
    u = u - u.mean()
    n = u.size
    t = np.arange(n) / fs
    spec = np.abs(np.fft.rfft(u * np.hanning(n)))
    k = int(np.argmax(spec[1:])) + 1
    df = fs / n

    def misfit(f):
        design = np.column_stack([np.cos(2 * np.pi * f * t), np.sin(2 * np.pi * f * t)])
        c, *_ = np.linalg.lstsq(design, u, rcond=None)
        return float(np.sum((u - design @ c) ** 2))

    res = minimize_scalar(misfit, bounds=(max((k - 1) * df, 0.5 * df), (k + 1) * df),
                          method="bounded", options={"xatol": 1e-6 * df})
    return float(res.x), 1.0 - res.fun / float(u @ u)


def quadrature_drive(drive, fs, freq):
    """The sine ``drive`` (offset removed) advanced by a quarter period:
    ``a cos + b sin`` becomes ``b cos - a sin``, the drive whose response
    is ``irfft(i X)`` for the drive's steady-state response ``irfft(X)``."""
    t = np.arange(drive.size) / fs
    c, s = np.cos(2 * np.pi * freq * t), np.sin(2 * np.pi * freq * t)
    coef, *_ = np.linalg.lstsq(np.column_stack([c, s, np.ones(drive.size)]), drive, rcond=None)
    return coef[1] * c - coef[0] * s


class SineModel(TimeModel):
    """:class:`TimeModel` with ``m = Re(rho) p + Im(rho) q``: ``p`` from
    ``predictor`` (the drive), ``q`` from ``quadrature`` (the quadrature
    drive, :func:`quadrature_drive`); without ``quadrature``, ``q`` is
    ``predictor``'s spectrum times ``i``, right only for a drive periodic in
    the FFT buffer."""

    names = ("log_amplitude_ratio", "phase_rad")
    ndim = 2
    #: An AR alone: the sine's information is at ``f0``, where the AR follows
    #: the noise (its 200-run calibration, docs/validation/coil.md).
    d_grid = (0.0,)

    def __init__(self, x, fs, predictor, skip, quadrature=None):
        self._cache = {}
        self.quadrature = quadrature
        super().__init__(x, fs, predictor, skip)

    def set_noise(self, a, s2, d=0.0):
        self._cache = {}
        super().set_noise(a, s2, d)

    def bounds(self):
        return np.array([np.log(0.1), -np.pi]), np.array([np.log(10.0), np.pi])

    def estimate_noise(self, theta):
        """AR noise model from the residual at ``theta`` (after ``skip``) less
        its sine at ``f0``, fitted by least squares under a Hann taper (whose
        side lobes keep the red noise below ``f0`` out of it): a residual
        left at ``f0`` by an imperfect ``theta`` would teach the
        autoregression a peak there, and its whitening would then hide the
        sine from the likelihood (at a sine far above red noise, the fit
        then runs to the amplitude's bound). As the likelihood does, the
        prefilter runs over the whole record and the first ``skip`` samples
        are left out after it."""
        r = self.raw_residual(theta)
        pq = self.predict(np.array([[0.0, 0.0], [0.0, np.pi / 2]])).T
        w = np.sqrt(np.hanning(r.size - self.skip))[:, None]
        coef, *_ = np.linalg.lstsq(w * pq[self.skip:], w[:, 0] * r[self.skip:], rcond=None)
        self.fit_noise(r - pq @ coef)

    def predict(self, theta, weight=None):
        theta = np.atleast_2d(theta)
        key = "raw" if weight is None else "whitened"
        if key not in self._cache:
            if self.quadrature is None:
                self._cache[key] = self.predictor(np.array([[1.0], [1j]]), weight)   # p, q
            else:
                one = np.ones((1, 1))
                self._cache[key] = np.concatenate([self.predictor(one, weight),
                                                   self.quadrature(one, weight)])
        pq = self._cache[key]
        rho = np.exp(theta[:, 0]) * np.exp(1j * theta[:, 1])
        return rho.real[:, None] * pq[0][None] + rho.imag[:, None] * pq[1][None]


@dataclass
class SineFit:
    """Posterior of the response at one frequency from a sine run."""

    channel: str
    freq_hz: float
    nominal: complex            # nominal response at f0 (counts per m/s)
    theta: np.ndarray           # (N, 2) ln A, phi
    convergence: object         # a Convergence (Chain.convergence())
    adequacy: dict
    response: object
    meta: dict = field(default_factory=dict)
    model: object = field(default=None, repr=False)
    kind: str = "sine"
    spec: object = None

    def physical(self):
        """Samples: amplitude ratio, phase difference (deg), response
        amplitude (counts per m/s) and phase (deg) at ``f0``."""
        a, phi = np.exp(self.theta[:, 0]), self.theta[:, 1]
        return {"amplitude_ratio": a, "phase_difference_deg": np.degrees(phi),
                "response_amplitude": a * abs(self.nominal),
                "response_phase_deg": np.degrees(np.angle(self.nominal) + phi)}

    def report_arrays(self):
        """What the report draws (as :meth:`bayescal.coil.result.CalFit.report_arrays`):
        the samples, the time series at the posterior median and the corner
        plot's columns (amplitude ratio, phase difference)."""
        phys = self.physical()
        out = {"theta": self.theta, "names": np.array(self.model.names),
               "corner_samples": np.column_stack([phys["amplitude_ratio"],
                                                  phys["phase_difference_deg"]]),
               "corner_labels": np.array(["amplitude / nominal", "phase - nominal (deg)"])}
        out.update(self.model.report_series(np.median(self.theta, axis=0)))
        return out

    def summary(self):
        """The ``cal.json`` content (kind ``sine``)."""
        params = {k: interval_summary(v) for k, v in self.physical().items()}
        return {"schema": SCHEMA, "kind": "sine", "channel": self.channel,
                "fit": "response at the sine's frequency", "frequency_hz": self.freq_hz,
                "parameters": params,
                "nominal": {"response_amplitude": abs(self.nominal),
                            "response_phase_deg": float(np.degrees(np.angle(self.nominal)))},
                "units": {"response_amplitude": "counts per m/s (velocity, whole response)",
                          "phase": "degrees"},
                "convergence": self.convergence.summary(), "adequacy": self.adequacy,
                "meta": self.meta}


def fit_sine(run, coil_constant, seed=0, progress=False, **sample_kw):
    """Posterior of the response at the sine's frequency from a sine run
    (``run`` restricted to one output). Returns a :class:`SineFit`."""
    if len(run.axes) != 1:
        raise ValueError("fit_sine takes a run with one output (CalRun.select)")
    x, u = checked_arrays(run)
    u = u - u.mean()
    if not np.ptp(u) > 0:
        raise InputError(f"{run.source}: the input channel holds no sine (it is constant)")
    f0, frac = sine_frequency(u, run.fs)
    if frac < MIN_SINE_FRACTION:
        raise InputError(f"{run.source}: the input is not a single sine (the best sine, at "
                         f"{f0:.4g} Hz, explains {100 * frac:.0f} % of its variance)")
    fam = run.families[0]
    decay = fam.period_s / (2 * np.pi * max(fam.damping, 0.05))
    skip = int(SETTLE_DECAYS * decay * run.fs)
    if x.size < 2 * skip or x.size * f0 / run.fs < 10:
        raise InputError(f"{run.source}: the sine run is too short: {x.size / run.fs:.0f} s; "
                         f"needs twice the settling time ({2 * skip / run.fs:.0f} s) and 10 "
                         "cycles")
    # the drive: the fitted sine, not the input channel's noise (coil.drive)
    drive, drive_sd = sine_drive(u, run.fs, f0)
    transfer, pad = coil_transfer(run, coil_constant), padding(fam, run.fs)
    model = SineModel(x, run.fs, Predictor(drive, run.fs, transfer, pad), skip,
                      Predictor(quadrature_drive(drive, run.fs, f0), run.fs, transfer, pad))
    # start: least squares of x on (p, q) with offset and drift
    design = np.column_stack([model.predict(np.array([0.0, 0.0]))[0],
                              model.predict(np.array([0.0, np.pi / 2]))[0], model.nuisance])
    c, *_ = np.linalg.lstsq(design[skip:], x[skip:], rcond=None)
    rho = complex(c[0], c[1])
    if not 0.1 < abs(rho) < 10:
        raise FitError(f"{run.source}: the response at {f0:.4g} Hz comes out {abs(rho):.3g} "
                       "times the nominal: check --coil-constant")
    theta0 = np.array([np.log(abs(rho)), np.angle(rho)])
    with single_threaded_blas():
        model.estimate_noise(theta0)
        theta, cov = least_squares_time(model, theta0)
        chain = sample(model, theta, cov, seed=seed, progress=progress, **sample_kw)
    med = np.median(chain.samples, axis=0)
    model.estimate_noise(med)
    nominal = complex(run.nominal_response(np.array([f0]))[0, 0])
    meta = {"source": run.source, "sampling_rate": run.fs, "coil_constant": coil_constant,
            "duration_s": x.size / run.fs, "settle_s": skip / run.fs,
            "sine_fraction_of_input": frac, "sampler": chain.sampler}
    meta["drive_sd"] = drive_sd
    return SineFit(run.ids[0], f0, nominal, with_drive_error(chain.samples, drive_sd, seed),
                   chain.convergence(),
                   model.adequacy(med), run.responses[0], meta, model)
