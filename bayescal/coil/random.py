"""Random (broadband, e.g. pseudo-random binary) calibration of one output
channel: the transfer function from the input-output cross-spectra, with the
noise model measured from the residual's power and the correlations of its
bins and segments computed from the recorded input (the likelihood of
:class:`bayescal.coil.element.RunModel`, one output with coefficient 1), and
the response parametrised by :class:`bayescal.coil.hf.PZSpec` (``--fit lp``,
``hf`` or ``all``).

The fit is the one of ``bayescal uvw`` (:func:`bayescal.coil.element.fit_two_pass`):
the least-squares point of a first pass (outputs deconvolved by the nominal
response) deconvolves the outputs again (second pass), so that what the
segment windows smooth is the nearly flat ratio of true to fitted response;
the posterior is sampled on the second pass.
"""
from __future__ import annotations

import numpy as np

from ..core.priors import Priors
from ..errors import InputError
from .element import RunModel, fit_two_pass
from .hf import PZSpec, iw_powers, poly_at_iw, scale_start
from .result import CalFit
from .runs import default_band

#: Default lower band edge of ``--fit hf`` in natural frequencies: far enough
#: above the corner that a few per cent error of the (fixed) long-period pair
#: changes the response by well under 0.1 %.
HF_FMIN_CYCLES = 10.0
#: Default upper band edge as a fraction of the sampling rate for hf/all fits.
HF_FMAX_FRACTION = 0.4


class PZModel(RunModel):
    """:class:`RunModel` of one output with the response of a :class:`PZSpec`."""

    def __init__(self, spectra, spec, base=None, band_variance=None):
        super().__init__(spectra, [1.0], [spec.family], spec.family, spec.priors, base=base,
                         band_variance=band_variance)
        self.spec = spec
        self.names = spec.names
        self.ndim = spec.ndim
        self.pendulum_index = spec.pendulum_index
        self._lo, self._hi = spec.bounds()
        # the likelihood's hot path: ratio = (G / G_nom) C(s) / |C(s_n)| Z(s) / P(s)
        # |P(s_n) / Z(s_n)| (PZSpec.polynomials), the constant factors, the
        # deconvolution and the input's power folded into one kernel, the
        # polynomials evaluated at i omega by real matrix products
        fam = spec.family
        sn = 2j * np.pi * fam.norm_freq
        c = spec.constant_factor(self._s) / abs(spec.constant_factor(np.array([sn]))[0])
        kernel = c / self.base[0] * self.input_power / fam.gain
        self._kernel_re, self._kernel_im = kernel.real.copy(), kernel.imag.copy()
        p, z = spec.polynomials(spec.nominal_theta())
        degree = max(p.shape[1], z.shape[1]) - 1
        self._powers = iw_powers(2 * np.pi * self.spectra.freqs, degree)
        self._powers_n = iw_powers([2 * np.pi * fam.norm_freq], degree)

    def bounds(self):
        return self._lo, self._hi

    def ratio(self, theta):
        return self.spec.ratio(self.spectra.freqs, theta)[:, None, :] / self.base[None]

    def band_model(self, theta):
        """``sum_{f in b} ratio(f; theta) / base(f) |A(f)|^2`` per band, (W, B):
        the model term of :meth:`residual`."""
        theta = np.atleast_2d(theta)
        p, z = self.spec.polynomials(theta)
        pr, pi = poly_at_iw(p, self._powers)
        nr, ni = poly_at_iw(p, self._powers_n)
        amp = np.exp(theta[:, self.spec.i_gain]) * np.hypot(nr, ni)[:, 0]
        den = pr * pr + pi * pi
        if z.shape[1] > 1:                              # Z / P = Z conj(P) / |P|^2
            zr, zi = poly_at_iw(z, self._powers)
            nr, ni = poly_at_iw(z, self._powers_n)
            amp = amp / np.hypot(nr, ni)[:, 0]
            rr, ri = (zr * pr + zi * pi) / den, (zi * pr - zr * pi) / den
        else:
            rr, ri = pr / den, -pi / den
        kr, ki = self._kernel_re, self._kernel_im
        re = np.add.reduceat(rr * kr - ri * ki, self._starts, axis=1)
        im = np.add.reduceat(rr * ki + ri * kr, self._starts, axis=1)
        return amp[:, None] * (re + 1j * im)

    def residual(self, theta):
        return (self._cya_b[None] - self.band_model(theta)[:, None, :]).transpose(0, 2, 1)

    def measured(self):
        """Per band: the measured transfer over ``nominal * base`` and its sd."""
        t = self._cya_b[0] / self.band_input_power
        sd = np.sqrt(self.sigma[:, 0, 0].real * self.inflation / self.band_input_power)
        return t, sd

    def measured_response(self):
        """Per band: the centre frequency (weighted by the input's power),
        the measured response over the nominal and its sd (``measured``
        with the deconvolution ``base`` put back, at each band's centre)."""
        t, sd = self.measured()
        w = self.input_power[:, None] * self.band_membership              # (F, B) weights
        fc = (self.spectra.freqs @ w) / w.sum(axis=0)
        rel = (self.base[0] * self.input_power) @ self.band_membership / self.band_input_power
        return fc, t * rel, sd * np.abs(rel)


def default_cal_band(run, fit):
    """Band of a random run: :func:`default_band` for ``lp``; for ``hf``
    from ``HF_FMIN_CYCLES`` natural frequencies to ``HF_FMAX_FRACTION fs``;
    for ``all`` from the lp band's lower edge to the same top."""
    fam = run.families[0]
    dur = run.data.shape[1] / run.fs
    lp = default_band(run.fs, dur, fam.period_s)
    top = HF_FMAX_FRACTION * run.fs
    if fit == "lp":
        return lp
    if fit == "hf":
        seg_min = 16.0 / dur                                 # at least ~16 periods recorded
        return max(HF_FMIN_CYCLES / fam.period_s, seg_min), top
    return lp[0], top


def fit_random(run, coil_constant, fit="lp", band=None, seed=0, progress=False, nperseg=None,
               priors=Priors(), **sample_kw):
    """Posterior of one output channel's response from a random calibration
    run (``run`` restricted to that output), under ``priors`` (the
    tolerances of period and damping). Returns a :class:`CalFit`."""
    if len(run.axes) != 1:
        raise ValueError("fit_random takes a run with one output (CalRun.select)")
    band = tuple(band) if band is not None else default_cal_band(run, fit)
    if band[1] > run.fs / 2:
        raise InputError(f"{run.source}: band top {band[1]:g} Hz is above Nyquist "
                         f"({run.fs / 2:g} Hz)")
    spec = PZSpec.from_response(run.responses[0], fit, band[1], source=run.source, priors=priors)

    def start(model):
        theta0 = spec.nominal_theta()
        return scale_start(run, spec, theta0, model.transfer_scale(theta0))

    model, chain, _, _, _ = fit_two_pass(run, coil_constant, band, nperseg,
                                         lambda sp, base, bv: PZModel(sp, spec, base, bv), start,
                                         spec.ratio, seed=seed, progress=progress, **sample_kw)
    return CalFit.from_chain("random", run, spec, model, chain, coil_constant, band)
