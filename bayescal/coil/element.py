"""Likelihood and fit of one element from one calibration run: the model of a
run (see :mod:`bayescal.coil.uvw`), its least-squares start and posterior.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..core.response import (NAMES as PENDULUM_NAMES, damping_over_period, set_by_prior_entries,
                             to_physical as pendulum_to_physical, pendulum_coefficients,
                             pendulum_denominator)
from ..core.sampling import sample
from ..errors import FitError, InputError, SpectraError
from ..core.fit import refine
from ..core.priors import Priors
from ..core.posterior import interval_summary
from ..core.spectra import cross_spectra
from .bandvariance import BandVariance
from .bounded import BoundedPosterior, mark_set_by_prior, prior_meta
from .triaxial import PARAMS
from .runs import BANDS_PER_DECADE, EDGE_PERIODS, calibration_nperseg


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


def _run_spectra(run, coil_constant, band, nperseg, base):
    def out_resp(f):
        h = run.nominal_response(np.asarray(f, float))
        return h if base is None else h * base(f)

    def in_resp(f):
        return (2j * np.pi * np.asarray(f) / coil_constant)[None, :]

    return cross_spectra(run.data, run.input[None, :], run.fs, out_resp, in_resp, band,
                         nperseg=nperseg or calibration_nperseg(run.fs, band[0], run.data.shape[1]),
                         bands_per_decade=BANDS_PER_DECADE, min_bins=8, sut_ids=run.ids,
                         ref_ids=["input"], edge_periods=EDGE_PERIODS)


#: Eigenvalues of a band's noise covariance are floored at this fraction of
#: its largest one, and every variance at ``SIGNAL_FLOOR`` of the output's
#: power: noise of rank below the number of outputs (one noise source seen
#: through the geometry, or a noise-free simulation) and round-off at very
#: high signal-to-noise otherwise leave it singular or indefinite.
EIGEN_FLOOR = 1e-4
SIGNAL_FLOOR = 1e-12


def regularise(sigma, power):
    """Hermitian ``sigma`` (B, n, n) made positive definite: eigenvalues
    floored at ``EIGEN_FLOOR`` of the largest and at ``SIGNAL_FLOOR`` of the
    band's mean output power ``power`` (B, n)."""
    w, v = np.linalg.eigh(sigma)
    floor = np.maximum(EIGEN_FLOOR * w[:, -1:], SIGNAL_FLOOR * power.max(axis=1, keepdims=True))
    w = np.maximum(w, np.maximum(floor, np.finfo(float).tiny))
    return np.einsum("bij,bj,bkj->bik", v, w, v.conj())


class RunModel(BoundedPosterior):
    """Posterior of one element's ``theta = (c0_rel, c1_rel, ln G)`` from one
    run: the pendulum pair in the coordinates the data see, relative to the
    ``nominal`` family's period and damping (:mod:`bayescal.core.response.pendulum`),
    under the stated prior of ``priors`` (period and damping tolerances),
    and the gain log-uniform within ``priors.gain_factor`` of nominal.

    ``coef`` is ``m_c`` per output, ``families`` the outputs' parametric
    responses, ``base`` (n_out, F) the response ratio the spectra were
    deconvolved by (ones at first), ``band_variance`` the run's
    :class:`bayescal.coil.bandvariance.BandVariance` (every fit passes it;
    without it :meth:`estimate_noise` takes the bins as independent,
    ``c_b = 1``, about half the variance of a Hann-windowed, half-overlapped
    band residual). Vectorised: ``log_prob(theta (W, 3))``.
    """

    names = (*PENDULUM_NAMES, "log_gain")
    ndim = 3
    pendulum_index = 0
    #: ``-log L`` is the whitened residual's squared norm.
    LIKELIHOOD_SCALE = 1.0

    def __init__(self, spectra, coef, families, nominal, priors=Priors(), base=None,
                 band_variance=None):
        self.spectra = spectra
        self.band_variance = band_variance
        self.coef = np.asarray(coef, float)
        self.families = families
        self.nominal = nominal
        self.priors = priors
        no = spectra.n_u
        f = spectra.freqs
        self.base = np.ones((no, f.size), complex) if base is None else base
        t = spectra.total
        # public views of the spectra: C_yA (F, no), S_AA (F,), the (F, B)
        # one-hot band membership of the bins and S_AA,b (B,) (set below)
        self.output_input = t[:, :no, no]
        self.input_power = t[:, no, no].real
        self._cyy = t[:, :no, :no]
        self.band_membership = np.eye(spectra.n_bands)[spectra.band_of]
        self._starts = np.r_[0, np.flatnonzero(np.diff(spectra.band_of)) + 1]
        # TwoPoleFamily.ratio split into per-frequency constants and the one
        # factor that depends on (T, h): 1 / D(s; T, h), shared by all outputs
        self._s = 2j * np.pi * f
        self._sn = 2j * np.pi * np.array([fam.norm_freq for fam in families])
        # D = s^2 + c1 s + c0 with c0 = c0_rel w0n^2, c1 = c1_rel 2 h_n w0n
        c1, c0 = pendulum_coefficients(nominal.period_s, nominal.damping)
        self._c_nom = np.array([c0, c1])
        d_nom = np.array([pendulum_denominator(self._s, *pendulum_coefficients(
            fam.period_s, fam.damping)) for fam in families])          # (no, F)
        self._dn_norm = np.array([abs(pendulum_denominator(sn, *pendulum_coefficients(
            fam.period_s, fam.damping))) for fam, sn in zip(families, self._sn)])
        self._g_nom = np.array([fam.gain for fam in families])
        self._const = d_nom / self.base                               # (no, F)
        self._kernel = self.coef[:, None] * self._const * self.input_power[None]
        self._cya_b = self.output_input.T @ self.band_membership          # (no, B)
        self.band_input_power = self.input_power @ self.band_membership
        self.noise = None
        self.sigma = None
        self.inflation = None

    def bounds(self):
        g = self.nominal.gain
        return (np.array([0.0, 0.0, np.log(g / self.priors.gain_factor)]),
                np.array([np.inf, np.inf, np.log(g * self.priors.gain_factor)]))

    def _factors(self, theta):
        """(W, no) gain and normalisation factor and (W, F) ``1 / D(s; T, h)``."""
        theta = np.atleast_2d(theta)
        c0 = (theta[:, 0] * self._c_nom[0])[:, None]
        c1 = (theta[:, 1] * self._c_nom[1])[:, None]
        inv = 1.0 / pendulum_denominator(self._s, c1, c0)
        d_sn = np.abs(pendulum_denominator(self._sn[None], c1, c0))                 # (W, no)
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

    def log_likelihood(self, theta):
        r = self.residual(theta)
        return -np.einsum("wbi,bij,wbj->w", r.conj(), self.noise, r).real

    def whitened_residual(self, theta, chol):
        r = self.residual(theta)[0]                                  # (B, no)
        z = np.einsum("bji,bj->bi", chol.conj(), r)
        return np.concatenate([z.real.ravel(), z.imag.ravel()])

    def likelihood_residual(self, theta):
        """The whitened residual with the noise model as set."""
        return self.whitened_residual(theta, np.linalg.cholesky(self.noise))

    def posterior_residual(self, theta, chol):
        """The whitened residual and the pendulum prior's rows: least squares
        on it finds the posterior's mode."""
        return np.concatenate([self.whitened_residual(theta, chol), self.prior_residual(theta)])

    def estimate_noise(self, theta):
        """Plug-in noise model at ``theta``: per-band ``Sigma_b`` (the
        residual's power weighted by the input's) and inflation ``c_b`` (the
        correlations of bins and segments, from the recorded input:
        :mod:`bayescal.coil.bandvariance`); sets ``self.noise`` (B, no, no)."""
        sp = self.spectra
        no = sp.n_u
        mu = self.mu(theta)[0].T                                     # (F, no)
        cya, saa = self.output_input, self.input_power
        e = (self._cyy - cya[:, :, None] * mu.conj()[:, None, :]
             - mu[:, :, None] * cya.conj()[:, None, :]
             + saa[:, None, None] * mu[:, :, None] * mu.conj()[:, None, :])
        n_bins = sp.bins_per_band * sp.n_segments
        # the band residual sums C_yA - mu S_AA over the band's bins, so its
        # variance is sum_f S_NN(f) S_AA(f): the noise weighted by the input's
        # power, not its plain band mean (they differ where both vary across
        # a band, as 1/f^2 in velocity at the bottom of a coil run's band)
        sigma = (np.einsum("fb,fij->bij", self.band_membership, e * saa[:, None, None])
                 / (sp.n_segments * self.band_input_power)[:, None, None])
        sigma = regularise(0.5 * (sigma + sigma.conj().transpose(0, 2, 1)),
                           np.einsum("fb,fii->bi", self.band_membership, self._cyy).real / n_bins[:, None])
        s_inv = np.linalg.inv(sigma)
        # the bins' and segments' correlations, from the recorded input
        # (bayescal.coil.bandvariance)
        c = (np.ones(sp.n_bands) if self.band_variance is None else
             self.band_variance.inflation(np.einsum("fii->f", e).real / no, saa))
        self.sigma, self.inflation = sigma, c
        self.noise = s_inv / (c * self.band_input_power)[:, None, None]
        return self.noise

    def misfit(self, theta):
        """Per output, the mean over bands of ``|R_b,c|^2`` over its expected
        value: about 1 where the model (and the geometry) fits."""
        r = self.residual(theta)[0]
        return np.mean(np.abs(r) ** 2 / self.residual_variance(), axis=0)

    def residual_variance(self):
        """(B, n_out) expected ``|R_b,c|^2`` under the noise model as set."""
        return np.einsum("bii->bi", self.sigma).real * (self.inflation
                                                        * self.band_input_power)[:, None]

    def transfer_scale(self, theta):
        """Least-squares scale of the model transfer at ``theta`` to the data
        (its sign tells whether the geometry's polarity holds)."""
        mu = self.mu(theta)[0]
        num = np.sum((mu.conj() * self.output_input.T).real)
        den = np.sum(np.abs(mu) ** 2 * self.input_power[None])
        return num / den

    def apparent_coefficients(self, theta):
        """Least-squares ``m_c`` per output given the element response at
        ``theta``: equals the geometry's ``M[n, c]`` when the geometry is right."""
        rho = self.ratio(theta)[0]
        num = np.sum(rho.conj() * self.output_input.T, axis=1)
        den = np.sum(np.abs(rho) ** 2 * self.input_power[None], axis=1)
        return num / den


def nominal_start(model):
    """Nominal period and damping, and the least-squares scale of the nominal
    transfer to the data."""
    theta = np.array([1.0, 1.0, np.log(model.nominal.gain)])
    return theta, model.transfer_scale(theta)


def least_squares_run(model, theta0):
    """Weighted least squares (the pendulum prior's rows included: the
    posterior's mode) with the noise model re-estimated twice; returns
    ``(theta, covariance (2 J^T J)^-1)`` like :func:`bayescal.core.fit.run.least_squares_fit` (bounded trust-region
    passes, :func:`bayescal.core.fit.leastsq.refine`)."""
    lo, hi = model.bounds()
    return refine(model.posterior_residual, theta0, lo, hi, model.estimate_noise, 3,
                  noise_args=lambda: (np.linalg.cholesky(model.noise),), method="trf",
                  x_scale="jac")


def _check_enough_bands(run, spectra, band, n_params):
    """Refuse a run whose band residuals (two real numbers per band and
    output) are fewer than the parameters fitted: :class:`InputError`."""
    n_out = len(run.axes)
    if 2 * spectra.n_bands * n_out < n_params:
        dur = run.data.shape[1] / run.fs
        raise InputError(
            f"{run.source}: the band {band[0]:.3g}-{band[1]:.3g} Hz of this {dur:.0f}-s run "
            f"holds {spectra.n_bands} frequency band(s) of {spectra.nperseg / run.fs:.0f}-s "
            f"segments, too few for the {n_params} parameters fitted: record a longer run")


def fit_two_pass(run, coil_constant, band, nperseg, make_model, start, ratio_at, *, seed=0,
                 progress=False, **sample_kw):
    """The fit of one run shared by ``bayescal uvw`` (:func:`fit_run`) and
    ``bayescal cal --kind random`` (:func:`bayescal.coil.random.fit_random`).

    First pass: spectra of the outputs deconvolved by their nominal response,
    ``make_model(spectra, None, band_variance)`` (the run's
    :class:`bayescal.coil.bandvariance.BandVariance`, the same in both
    passes: it depends on the input alone), the start ``start(model) ->
    theta0``, least squares. Second pass: the outputs deconvolved again by
    the fitted response ``ratio_at(f, theta_ls) -> (n_out, F)`` (so the
    segment windows smooth only the nearly flat ratio of true to fitted
    response), ``make_model(spectra, base, band_variance)``, least squares,
    then the posterior sampled by :func:`bayescal.core.sampling.mcmc.sample`.
    Returns ``(model, chain, spectra, theta_ls, cov_ls)`` (the second pass's
    least-squares point and Laplace covariance).
    """
    sp = run_spectra(run, coil_constant, band, nperseg)
    variance = BandVariance(run, coil_constant, sp, band)
    model = make_model(sp, None, variance)
    theta = start(model)
    _check_enough_bands(run, sp, band, theta.size)
    theta, _ = least_squares_run(model, theta)
    t_ls = theta.copy()

    def base(f):
        return ratio_at(f, t_ls)

    sp = run_spectra(run, coil_constant, band, nperseg, base=base)
    model = make_model(sp, base(sp.freqs), variance)
    theta, cov = least_squares_run(model, theta)
    chain = sample(model, theta, cov, seed=seed, progress=progress, **sample_kw)
    return model, chain, sp, theta, cov


@dataclass
class ElementFit:
    """Posterior of one element from one run (possibly Z only)."""

    element: str
    outputs: list
    samples: np.ndarray          # (N, 3) period_s, damping, gain
    theta_ls: np.ndarray
    cov: np.ndarray
    convergence: object          # a Convergence (Chain.convergence())
    misfit: dict
    apparent: dict
    inflation: np.ndarray
    band_hz: tuple
    model: RunModel = field(repr=False, default=None)
    sampler: dict = field(default_factory=dict)     # what emcee ran (Chain.sampler)
    #: :func:`bayescal.core.response.pendulum.prior_sensitivity` of the element's pair
    prior_sensitivity: dict = field(default_factory=dict)
    response_prior: dict = field(default_factory=dict)

    def summary(self):
        out = {p: interval_summary(self.samples[:, j]) for j, p in enumerate(PARAMS)}
        # what a band above the corner fixes (bayescal.core.response.pendulum)
        out["damping_over_period"] = interval_summary(
            damping_over_period(self.samples[:, 0], self.samples[:, 1]))
        mark_set_by_prior(out, set_by_prior_entries(self.prior_sensitivity),
                          self.element)
        out["prior_sensitivity"] = self.prior_sensitivity.get(self.element, {})
        out["response_prior"] = self.response_prior
        out["outputs_used"] = self.outputs
        out["misfit"] = self.misfit
        out["apparent_coefficient"] = self.apparent
        out["convergence"] = self.convergence.summary()
        return out


def fit_run(run, m, coil_constant, band, nperseg=None, seed=0, progress=False,
            priors=Priors(), **sample_kw):
    """Posterior over one element's (period, damping, gain) from one run."""
    coef = run.coefficients(m)
    if np.all(np.abs(coef) < 1e-6):
        raise InputError(f"{run.source}: the outputs {run.axes} do not see element "
                         f"{run.element} in this geometry")
    nominal = run.families[-1]

    def make_model(sp, base, variance):
        return RunModel(sp, coef, run.families, nominal, priors, base=base,
                        band_variance=variance)

    def start(model):
        # start from the Z output when there is one: every element shows in Z
        # with the same sign in the built-in geometries, so a wrong X/Y sign
        # convention shows up as a misfit and a Z-only disagreement rather than
        # a failed start (an output that barely sees the element, e.g. Z in an
        # identity geometry, cannot give a start: then the output that sees it
        # most does)
        iz = run.axes.index("Z") if "Z" in run.axes else None
        if iz is None or abs(coef[iz]) < 0.1 * np.abs(coef).max():
            iz = None if len(run.axes) == 1 else int(np.argmax(np.abs(coef)))
        start_model = model if iz is None else RunModel(model.spectra.select([iz]), coef[[iz]],
                                                        [run.families[iz]], nominal, priors)
        theta0, scale = nominal_start(start_model)
        if not scale > 0:
            raise FitError(f"{run.source}: the outputs respond to the coil of {run.element} "
                           "with the opposite sign to the geometry: check the coil wiring, the "
                           "output polarity or the sensor matrix")
        theta0[2] += np.log(scale)
        lo, hi = model.bounds()
        if not lo[2] < theta0[2] < hi[2]:
            raise FitError(f"{run.source}: element {run.element}'s gain comes out "
                           f"{np.exp(theta0[2]):.4g}, more than {priors.gain_factor:g}x from "
                           f"nominal {nominal.gain:.4g}: check --coil-constant")
        return theta0

    def ratio_at(f, t):
        period, damping = pendulum_to_physical(t[0], t[1], nominal.period_s, nominal.damping)
        return np.stack([fam.ratio(f, period, damping, np.exp(t[2]))[0]
                         for fam in run.families])

    model, chain, sp, theta, cov = fit_two_pass(run, coil_constant, band, nperseg, make_model, start,
                                                ratio_at, seed=seed, progress=progress,
                                                **sample_kw)
    s = chain.samples
    phys = np.column_stack([*pendulum_to_physical(s[:, 0], s[:, 1], nominal.period_s,
                                                  nominal.damping), np.exp(s[:, 2])])
    med = np.median(s, axis=0)
    sensitivity = model.prior_sensitivity(s, run.element, n_eff=float(np.min(chain.ess)))
    app = model.apparent_coefficients(med)
    return ElementFit(
        element=run.element, outputs=list(run.axes), samples=phys, theta_ls=theta, cov=cov,
        convergence=chain.convergence(), misfit=dict(zip(run.axes, model.misfit(med).tolist())),
        apparent={a: {"estimate": float(v.real), "expected": float(c), "imag": float(v.imag)}
                  for a, v, c in zip(run.axes, app, coef)},
        inflation=model.inflation, band_hz=(float(sp.band_edges[0]), float(sp.band_edges[-1])),
        model=model, sampler=chain.sampler, prior_sensitivity=sensitivity,
        response_prior=prior_meta(priors))
