"""The result of one coil calibration of one output channel (any kind), and
its ``cal.json`` content (schema ``bayescal.cal/1``)."""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from scipy.stats import chi2

from ..core.response import damping_over_period, set_by_prior_entries, evaluate_velocity_response
from ..core.posterior import interval_summary
from .bounded import mark_set_by_prior, prior_meta

SCHEMA = "bayescal.cal/1"


def adequacy_summary(model, theta):
    """Band residuals at ``theta`` against their noise model: the mean of
    ``|R_b|^2 / E|R_b|^2`` (about 1 when the model fits) and the chi-square
    p-value of their sum (2 degrees of freedom per band and output)."""
    r = model.residual(theta)[0]
    q = np.abs(r) ** 2 / model.residual_variance()
    dof = 2 * q.size
    return {"misfit": float(q.mean()), "n_bands": int(q.shape[0]),
            "p_value": float(chi2.sf(2 * q.sum(), dof))}


@dataclass
class CalFit:
    """Posterior of one output channel from one calibration run."""

    kind: str                    # random, step or sine
    channel: str
    spec: object                 # PZSpec
    theta: np.ndarray            # (N, ndim) samples
    convergence: object          # a Convergence (Chain.convergence())
    adequacy: dict
    band_hz: tuple
    response: object             # the channel's nominal ObsPy Response
    meta: dict = field(default_factory=dict)
    model: object = field(default=None, repr=False)

    @classmethod
    def from_chain(cls, kind, run, spec, model, chain, coil_constant, band):
        med = np.median(chain.samples, axis=0)
        model.estimate_noise(med)
        adequacy = (model.adequacy(med) if hasattr(model, "adequacy")
                    else adequacy_summary(model, med))
        meta = {"source": run.source, "sampling_rate": run.fs, "coil_constant": coil_constant,
                "duration_s": run.data.shape[1] / run.fs, "sampler": chain.sampler}
        sensitivity = model.prior_sensitivity(chain.samples, run.ids[0],
                                              n_eff=float(np.min(chain.ess)))
        if sensitivity:
            meta.update({"prior_sensitivity": sensitivity[run.ids[0]],
                         "set_by_prior": set_by_prior_entries(sensitivity),
                         "response_prior": prior_meta(spec.priors)})
        return cls(kind, run.ids[0], spec, chain.samples, chain.convergence(), adequacy,
                   (float(band[0]), float(band[1])), run.responses[0], meta, model)

    def physical(self):
        return self.spec.physical(self.theta)

    def corner_columns(self):
        """``(samples (N, k), labels)`` of the fitted parameters in physical
        units, as the report's corner plot shows them."""
        phys = self.physical()
        cols, labels = [], []
        for p, lab in (("period_s", "period (s)"), ("damping", "damping"), ("gain", "gain")):
            if p in phys:
                cols.append(phys[p])
                labels.append(lab)
        for k, it in enumerate(self.spec.items):
            cols.append(phys["hf"][:, k].real)
            labels.append(f"{it.kind} {it.freq_hz:.3g} Hz re")
            if it.complex_pair:
                cols.append(phys["hf"][:, k].imag)
                labels.append(f"{it.kind} {it.freq_hz:.3g} Hz im")
        return np.column_stack(cols), labels

    def report_arrays(self):
        """Everything the report draws, as arrays (saved in ``cal_samples.npz``
        beside ``cal.json``; :mod:`bayescal.report.cal` reads them back):
        the samples, the response curves (:meth:`curves`), per band the
        measured response and the standardised residuals (random runs), the
        time series (step runs) and the corner plot's columns."""
        c = self.curves()
        corner, labels = self.corner_columns()
        out = {"theta": self.theta, "names": np.array(self.model.names),
               "curve_freqs": c["freqs"], "curve_nominal": c["nominal"],
               "curve_amp": c["amp"], "curve_phase": c["phase"],
               "corner_samples": corner, "corner_labels": np.array(labels)}
        med = np.median(self.theta, axis=0)
        if hasattr(self.model, "measured_response"):
            fc, ratio, sd = self.model.measured_response()
            r = self.model.residual(med)[0][:, 0]
            out.update(measured_freqs=fc, measured_ratio=ratio, measured_sd=sd,
                       measured_nominal=evaluate_velocity_response(self.response, fc),
                       band_centres=self.model.spectra.band_centres,
                       band_residual=r / np.sqrt(self.model.residual_variance()[:, 0] / 2))
        if hasattr(self.model, "report_series"):
            out.update(self.model.report_series(med))
        return out

    def summary(self):
        """The ``cal.json`` content."""
        phys = self.physical()
        fam = self.spec.family
        params = {}
        for p in ("period_s", "damping", "gain"):
            if p in phys:
                params[p] = interval_summary(phys[p])
        if "period_s" in phys:      # what a band above the corner fixes (core.response.pendulum)
            params["damping_over_period"] = interval_summary(
                damping_over_period(phys["period_s"], phys["damping"]))
            mark_set_by_prior(params, self.meta.get("set_by_prior", {}), self.channel)
        for kind in ("pole", "zero"):
            entries = []
            for k, it in enumerate(self.spec.items):
                if it.kind != kind:
                    continue
                q = phys["hf"][:, k]
                entries.append({"nominal": [it.nominal.real, it.nominal.imag],
                                "frequency_hz": it.freq_hz, "real": interval_summary(q.real),
                                "imag": (interval_summary(q.imag) if it.complex_pair
                                         else {"fixed": 0.0}),
                                "conjugate_pair": it.complex_pair})
            params[f"hf_{kind}s"] = entries
        fixed = {p: getattr(fam, p) for p in ("period_s", "damping") if p not in phys}
        return {"schema": SCHEMA, "kind": self.kind, "channel": self.channel, "fit": self.spec.fit,
                "parameters": params, "fixed_at_nominal": fixed,
                "nominal": {"period_s": fam.period_s, "damping": fam.damping, "gain": fam.gain},
                "set_by_prior": {k: v["reason"] for k, v in params.items()
                                 if isinstance(v, dict) and v.get("set_by_prior")},
                "units": {"gain": f"{fam.gain_units} (first stage) at {fam.norm_freq:g} Hz",
                          "damping_over_period": "1/s", "hf_poles": "rad/s"},
                "band_hz": list(self.band_hz), "convergence": self.convergence.summary(),
                "adequacy": self.adequacy, "meta": self.meta}

    def curves(self, n_freqs=150, n_samples=400, seed=0):
        """Response curves for the report: ``freqs``, ``nominal`` (counts per
        m/s), the fitted ratio's median and 95 % band of amplitude and phase
        (degrees) over the nominal."""
        f = np.geomspace(self.band_hz[0], self.band_hz[1], n_freqs)
        rng = np.random.default_rng(seed)
        idx = rng.choice(self.theta.shape[0], min(n_samples, self.theta.shape[0]), replace=False)
        r = self.spec.ratio(f, self.theta[idx])
        amp, ph = np.abs(r), np.degrees(np.angle(r))
        q = [2.5, 50, 97.5]
        return {"freqs": f, "nominal": evaluate_velocity_response(self.response, f),
                "amp": np.percentile(amp, q, axis=0), "phase": np.percentile(ph, q, axis=0)}
