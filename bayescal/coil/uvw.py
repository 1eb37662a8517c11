"""Coil-by-coil calibration of symmetric triaxial (UVW) sensors (seed 003).

Geometry and conventions (written down once, here)
--------------------------------------------------
``M`` is the UVW matrix of :mod:`bayescal.core.orientation.geometry`: rows U, V, W over
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
(:class:`bayescal.core.response.family.TwoPoleFamily`). Outputs are deconvolved to m/s by
their nominal response and the input to m/s by ``2 pi i f / C`` through
:func:`bayescal.core.spectra.welch.cross_spectra` (Welch, Hann, 50 % overlap). The
residual per narrow band b (20 per decade) is

    R_b,c(theta) = sum_{f in b} [ Y_c A^* - m_c rho_c(f; theta) |A|^2 ],

zero-mean at the truth; its covariance is ``c_b Sigma_b S_AA,b`` with
``Sigma_b`` the per-bin covariance of the output residual (full matrix across
outputs: element noise mixes into X, Y, Z) and ``c_b`` the ratio of the
band residual's variance to the independent-bin formula (the correlations
of neighbouring bins and of overlapping segments), computed from the
recorded input (:mod:`bayescal.coil.bandvariance`). After the least-squares fit the spectra are
recomputed deconvolved by the fitted response, so the residual's power that
sets ``Sigma_b`` is free of in-band model curvature."""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..core.response import damping_over_period, TwoPoleFamily
from ..core.priors import Priors
from ..errors import FitError, InputError
from ..core.posterior import interval_summary
from .triaxial import ELEMENTS, PARAMS, XYZ, cross_talk, response_matrix
from .element import RunModel, nominal_start, fit_run, run_spectra
from .runs import default_band


SCHEMA = "bayescal.uvw/1"

#: Calibrated by validation/studies/uvw_coverage.py: under the true model the
#: statistic's sd is 1.09-1.21 per parameter and |z| exceeds 3 in 0.6 % of
#: 360 draws, so 4 keeps false alarms near 1 % per nine-parameter calibration.
AGREEMENT_Z = 4.0

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
                         "damping_over_period": interval_summary(
                             damping_over_period(eq[:, 0], eq[:, 1])),
                         "gain": interval_summary(eq[:, 2] / scale),
                         "gain_at_norm_freq": interval_summary(self.xyz["gain_at_norm"][:, ax]
                                                               / scale),
                         "two_pole_misfit_max": float(np.max(self.xyz["equivalent_misfit"][:, ax]))}
            _mark_derived(xyz[name], {e: elements[e] for j, e in enumerate(ELEMENTS)
                                      if self.matrix[j, ax] ** 2 > 1e-6})
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


#: Quantiles (per cent) of the report's credible bands: the median and a 95 % band (the
#: level of uvw.json's intervals, which the report's table prints).
BAND_PERCENTILES = (2.5, 50, 97.5)


def _bands(x):
    """(3, ...) the ``BAND_PERCENTILES`` of ``x`` over its first axis (samples)."""
    return np.percentile(x, BAND_PERCENTILES, axis=0)


def report_arrays(result):
    """Everything the report draws besides ``uvw.json`` (saved in
    ``uvw_samples.npz``; :mod:`bayescal.report.uvw` reads them back): the
    samples (``joint``, ``element_<e>``, ``z_only_<e>``), the derived XYZ
    quantities, and over ``freqs`` the 95 % bands (``BAND_PERCENTILES``) of
    each element's and each XYZ axis's response over the nominal (amplitude
    ``*_amp``, phase in degrees ``*_phase``, shape (3, 3 quantiles, F)) and
    of the cross-talk of each pair X-Y, X-Z, Y-Z in per cent."""
    k = element_ratios(result.joint, result.family, result.freqs)
    t = result.xyz["ratio"]
    diag = np.stack([t[:, i, i] for i in range(3)], axis=1)
    d = np.abs(np.einsum("nllf->nlf", t))
    talk = np.stack([100 * (np.abs(t[:, i, j]) / np.sqrt(d[:, i] * d[:, j]))
                     for i, j in ((0, 1), (0, 2), (1, 2))], axis=1)
    return {"joint": result.joint, "freqs": result.freqs,
            **{f"element_{e}": f.samples for e, f in result.fits.items()},
            **{f"z_only_{e}": f.samples for e, f in result.z_fits.items()},
            "xyz_equivalent": result.xyz["equivalent"],
            "xyz_gain_at_norm": result.xyz["gain_at_norm"],
            "cross_talk": result.xyz["cross_talk"],
            "element_amp": np.stack([_bands(np.abs(k[:, j])) for j in range(3)]),
            "element_phase": np.stack([_bands(np.degrees(np.angle(k[:, j]))) for j in range(3)]),
            "xyz_amp": np.stack([_bands(np.abs(diag[:, j])) for j in range(3)]),
            "xyz_phase": np.stack([_bands(np.degrees(np.angle(diag[:, j]))) for j in range(3)]),
            "cross_talk_pairs": np.stack([_bands(talk[:, j]) for j in range(3)])}


def _mark_derived(entry, elements):
    """Mark an XYZ axis's period, damping or damping/period as set by the
    prior when it is for any element (``elements``: name -> summary) that
    the axis sees."""
    for name in ("period_s", "damping", "damping_over_period"):
        which = [e for e, s in elements.items() if s.get(name, {}).get("set_by_prior")]
        if which:
            entry[name].update({
                "set_by_prior": True,
                "reason": f"derived from element {', '.join(which)}, whose {name} the prior sets",
                "action": "not measured"})


def _pair(fits, n_max, rng):
    n = min(n_max, *(f.samples.shape[0] for f in fits))
    return np.stack([f.samples[rng.choice(f.samples.shape[0], n, replace=False)] for f in fits],
                    axis=1)


def calibrate_uvw(runs, m, *, coil_constant=None, band=None, z_only=False, seed=0,
                  progress=False, matrix_source="", nperseg=None, n_derived=2000, priors=Priors(),
                  **sample_kw):
    """Posterior over the three elements from coil-by-coil runs.

    Parameters
    ----------
    runs : dict element ("U", "V", "W") -> :class:`CalRun`.
    m : UVW matrix (rows U, V, W over columns X, Y, Z).
    coil_constant : m/s^2 per input count, or None (gains then relative).
    band : (fmin, fmax) Hz; default ``(0.5 / T_nom, min(25 / T_nom, fs / 4))``.
    z_only : use only each run's Z output (the seed's procedure).
    priors : :class:`bayescal.core.priors.Priors` (the tolerances of
        period and damping; the gain's range).
    """
    missing = [e for e in ELEMENTS if e not in runs]
    if missing:
        raise InputError(f"no calibration run for element(s) {', '.join(missing)}")
    fam = runs["U"].families[-1]
    if band is None:
        fs = min(r.fs for r in runs.values())
        band = default_band(fs, min(r.data.shape[1] / r.fs for r in runs.values()), fam.period_s)
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
                          priors=priors, what=f"element {e}", **sample_kw)
        sees_z = abs(m[ELEMENTS.index(e), 2]) > 1e-6
        if not z_only and has_z and len(runs[e].axes) > 1 and sees_z:
            z_fits[e] = fit_run(runs[e].select(["Z"]), m, c_eff, band, nperseg,
                                seed=seed + 10 + i, progress=progress, priors=priors,
                                what=f"element {e} from the Z output alone", **sample_kw)
    rng = np.random.default_rng(seed)
    joint = _pair([fits[e] for e in ELEMENTS], n_derived, rng)
    freqs = np.geomspace(band[0], band[1], 120)
    xyz = derive_xyz(joint, m, fam, freqs)
    mode = "z-only" if z_only else "all-outputs"
    meta = {"coil_constant": coil_constant, "coil_constant_used": c_eff,
            "response_prior": fits[ELEMENTS[0]].response_prior,
            "runs": {e: {"source": r.source, "outputs": r.ids, "sampling_rate": r.fs,
                         "duration_s": r.data.shape[1] / r.fs} for e, r in runs.items()},
            "sampler": {**{e: f.sampler for e, f in fits.items()},
                        **{f"{e} (Z only)": f.sampler for e, f in z_fits.items()}}}
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
        _, scale = nominal_start(model)
        if not scale > 0:
            raise FitError(f"{run.source}: the outputs respond to the coil of {e} with the "
                           "opposite sign to the geometry")
        logs.append(np.log(scale))
    return float(np.exp(np.mean(logs)))
