"""A catalogue of physics that the base calibration model leaves out.

Each entry is an :class:`bayescal.core.model.likelihood.Effect` (a factor on the SUT
deconvolution that equals 1 at the effect's null value, so the extended model
nests the base model), a *signature* test that scores how well the misfit
located after the base fit looks like it, and a sentence in plain words.

Signatures read the per-band complex ratio ``q[b, i]`` of what SUT channel
``i`` recorded over what the fitted model predicts from the reference (1
where the model fits; see :func:`bayescal.criticism.diagnose.band_ratio`):

* ``timing_offset``: phase of ``q`` linear in frequency through the origin,
  flat amplitude (SUT late by tau: phase ``-2 pi f tau`` on every channel).
* ``clock_drift``: the per-segment timing (phase slope) changes steadily
  through the record (a screen; the drift is fitted on the per-time-block
  likelihood, :class:`ClockDrift`, then carried to the errors-in-variables
  model with its rate taken out of the spectra, :class:`CorrectedDrift`).
* ``extra_pole``: amplitude rolls off (SUT has a pole its metadata lacks:
  ``|q|`` falls, phase lags) or rises (the reference lacks one: ``|q|``
  rises, phase leads) toward high frequency.
* ``gain_error``: one channel's ``|q|`` flat and different from 1, phase 0.
* ``polarity_reversal`` / ``channel_swap``: the base fit estimates
  orientation freely, so these show as a fitted axis opposite to the
  metadata axis, or two channels whose fitted axes match each other's
  metadata axes (:func:`bayescal.criticism.wiring.orientation_findings`, a
  screen; the score is :func:`bayescal.criticism.search.orientation_score`).
* ``tilt_noise``: noise, not a response error, modelled in the noise
  spectra by :mod:`bayescal.criticism.tilt`. :func:`tilt_signature` is the earlier
  coherence-ratio rule, kept as the baseline of validation/studies/tilt_power.py.
"""
from __future__ import annotations

from dataclasses import replace

import numpy as np

from ..core.response import pendulum
from ..core.model import Effect

#: Horizontal/vertical coherence-deficit ratio (two lowest bands) naming tilt noise.
TILT_RATIO = 4.0
#: A missing pole is named only with its corner below this many times the band top.
IDENTIFIABLE_RATIO = 3.0


class TimingOffset(Effect):
    """The SUT's clock is late by ``seconds`` relative to the reference's."""

    name = "timing_offset"
    param_names = ("seconds",)
    multimodal = True

    def __init__(self, rows, limit_s=30.0):
        self.rows = list(rows)
        self.limit_s = limit_s

    def factor(self, f, p):
        return np.exp(2j * np.pi * f[None, None, :] * p[:, :1, None])

    def log_prior(self, p):
        return np.where(np.abs(p[:, 0]) < self.limit_s, 0.0, -np.inf)

    @staticmethod
    def physical(p):
        return {"seconds": p[:, 0]}

    @staticmethod
    def explain(med):
        s = med["seconds"]
        return (f"the SUT's clock is {abs(s):.3g} s {'late' if s > 0 else 'early'} relative to "
                "the reference's (a timing offset between the digitizers)")


class ClockDrift(Effect):
    """The SUT's clock offset grows linearly through the record:
    ``tau(t) = seconds_mid + ppm * 1e-6 * (t - t_mid)`` (``t_mid`` the mean
    time of the used segments). A time-dependent effect (``blocked``): in
    time block ``g`` of the spectra (segment times with mean ``t_g`` and
    variance ``v_g``) the block's cross-spectra carry the block average of
    ``exp(-2 pi i f tau(t))``, i.e. ``exp(-2 pi i f tau(t_g))`` times the
    decoherence within the block, ``exp(-(2 pi f ppm 1e-6)^2 v_g / 2)``;
    the SUT factor undoes both
    (second-order cumulant; the phase spread inside a 16th of an hour-long
    record at 100 ppm and 3 Hz is 0.4 rad, where the next term is below
    1e-3). The block-to-block phase progression carries the rate and its
    sign, so both parameters come from the posterior. ``ppm = 0`` is a
    constant offset: the effect nests :class:`TimingOffset`."""

    name = "clock_drift"
    param_names = ("seconds_mid", "ppm")
    blocked = True
    multimodal = True
    #: The parameters whose null value is the effect's absence (a drift's
    #: rate; its offset at mid-record alone is a timing offset).
    absence = (1,)

    def __init__(self, rows, spectra, limit_ppm=1000.0):
        self.rows = list(rows)
        t = spectra.segment_times()
        g = spectra.block_of
        n_blocks = spectra.block_totals.shape[0]
        count = np.maximum(np.bincount(g, minlength=n_blocks), 1)
        self.t_mid = float(t.mean())
        self.dt = spectra.block_times() - self.t_mid                          # (G,)
        self.var = np.maximum(np.bincount(g, t * t, n_blocks) / count
                              - (self.dt + self.t_mid) ** 2, 0.0)
        self.limit_ppm = limit_ppm

    def factor(self, f, p):
        tau = p[:, 0, None] + 1e-6 * p[:, 1, None] * self.dt[None, :]        # (W, G)
        w = 2 * np.pi * f[None, None, :]
        spread = np.maximum(np.exp(-0.5 * (w * 1e-6 * p[:, 1, None, None]) ** 2
                                   * self.var[None, :, None]), 0.05)
        # the block sum carries exp(-i w tau_g) * spread; the factor undoes both
        return (np.exp(1j * w * tau[:, :, None]) / spread)[:, :, None, :]    # (W, G, 1, F)

    def log_prior(self, p):
        ok = (np.abs(p[:, 0]) < 30) & (np.abs(p[:, 1]) < self.limit_ppm)
        return np.where(ok, 0.0, -np.inf)

    @staticmethod
    def physical(p):
        return {"seconds_mid": p[:, 0], "ppm": p[:, 1]}

    @staticmethod
    def explain(med):
        s = med["ppm"]
        return (f"the SUT's clock {'gains' if s > 0 else 'loses'} {abs(s):.3g} ppm against the "
                f"reference's (its offset grows through the record; {med['seconds_mid']:.3g} s "
                "at mid-record, + = SUT late)")


class CorrectedDrift(TimingOffset):
    """A clock drift (see :class:`ClockDrift`) whose rate has been taken out
    of the spectra (:func:`drift_corrected`): what is left of it is a constant
    offset, ``seconds_mid``, so the model needs no per-time-block likelihood
    and keeps its errors-in-variables treatment of the reference's
    self-noise. The rate ``ppm`` is measured by its profile likelihood under
    that model (the spectra corrected at each trial rate, the other
    parameters re-fitted): its posterior is taken as Gaussian with the
    profile's curvature, independent of the rest. Not dropped by the
    backward elimination (its evidence is the per-block comparison that named
    it; the corrected spectra have no drift left to test)."""

    name = "clock_drift"
    param_names = ("seconds_mid",)
    prunable = False

    def __init__(self, rows, ppm, ppm_sd, limit_s=30.0, dispersion=1.0):
        super().__init__(rows, limit_s)
        self.ppm, self.ppm_sd = float(ppm), float(ppm_sd)
        #: the misfit the per-block model left (its median standardised
        #: misfit): further effects must beat it (:func:`.naming.prune_overdispersed`)
        self.dispersion = float(dispersion)

    def physical(self, p):
        rng = np.random.default_rng(0)
        return {"seconds_mid": p[:, 0], "ppm": rng.normal(self.ppm, self.ppm_sd, p.shape[0])}

    explain = staticmethod(ClockDrift.explain)


def drift_corrected(spectra, drift, ppm):
    """``spectra`` with the time-varying part of a clock drift of ``ppm``
    taken out: in time block ``g`` the SUT-reference cross-spectra are
    multiplied by :class:`ClockDrift`'s factor at zero mid-record offset
    (its phase and its within-block decoherence undone), each segment's
    band sums by the phase at the band's centre; the SUT's own spectra do
    not change. ``drift``: the :class:`ClockDrift` of these spectra (its
    block times)."""
    sp, nu = spectra, spectra.n_u
    p = np.array([[0.0, float(ppm)]])
    rot = drift.factor(sp.freqs, p)[0, :, 0]                                     # (G, F)
    blocks = np.array(sp.block_totals, dtype=complex)
    change = np.zeros_like(blocks)
    change[:, :, :nu, nu:] = blocks[:, :, :nu, nu:] * (rot - 1)[:, :, None, None]
    change[:, :, nu:, :nu] = blocks[:, :, nu:, :nu] * (np.conj(rot) - 1)[:, :, None, None]
    total = sp.total + change.sum(axis=0)
    t = sp.segment_times() - drift.t_mid
    seg = np.array(sp.per_segment, dtype=complex)
    ph = np.exp(2j * np.pi * sp.band_centres[None, :] * 1e-6 * float(ppm) * t[:, None])  # (K, B)
    seg[:, :, :nu, nu:] *= ph[:, :, None, None]
    seg[:, :, nu:, :nu] *= np.conj(ph)[:, :, None, None]
    return replace(sp, total=total, per_segment=seg,
                   block_totals=(blocks + change).astype(sp.block_totals.dtype))


class ExtraPole(Effect):
    """A real pole at ``corner_hz`` missing from the metadata of the SUT
    (``which="sut"``) or of the reference (``which="ref"``), normalised like
    the first stage (unit gain at ``norm_freq``). Parameter: ``1 / corner``
    in seconds (0 = no pole; the prior keeps it positive)."""

    name = "extra_pole"
    param_names = ("inverse_corner_s",)

    def __init__(self, rows, which, norm_freq=1.0, max_inverse_s=100.0):
        self.rows = list(rows)
        self.which = which
        self.norm_freq = norm_freq
        self.max_inverse_s = max_inverse_s

    def factor(self, f, p):
        x = p[:, :1, None]
        undo = (1 + 1j * f[None, None, :] * x) / np.abs(1 + 1j * self.norm_freq * x)
        return undo if self.which == "sut" else 1.0 / undo

    def log_prior(self, p):
        return np.where((p[:, 0] >= 0) & (p[:, 0] < self.max_inverse_s), 0.0, -np.inf)

    @staticmethod
    def identifiable(p, fmin, fmax):
        """A corner far above the band only adds a near-linear phase and a
        gain step (a delay and a gain): not identifiable as a pole there."""
        return p[0] * fmax * IDENTIFIABLE_RATIO >= 1.0

    @staticmethod
    def physical(p):
        with np.errstate(divide="ignore"):
            return {"corner_hz": 1.0 / np.maximum(p[:, 0], 1e-12)}

    def explain(self, med):
        who, other = (("sensor under test", "reference") if self.which == "sut"
                      else ("reference", "sensor under test"))
        return (f"the {who}'s response has a pole near {med['corner_hz']:.3g} Hz that its "
                "metadata lacks (its amplitude rolls off and its phase lags above that; a "
                f"pair of recordings cannot tell this from a zero missing from the {other}'s "
                "metadata)")


class GainError(Effect):
    """SUT channel ``row``'s sensitivity is ``1 + fraction`` times its
    metadata value (only testable when gains are not fitted)."""

    name = "gain_error"
    param_names = ("fraction",)

    def __init__(self, row, channel_id=""):
        self.rows = [row]
        self.channel_id = channel_id

    def factor(self, f, p):
        return (1.0 / (1.0 + p[:, :1, None])) * np.ones_like(f)[None, None, :]

    def log_prior(self, p):
        return np.where(np.abs(p[:, 0]) < 0.9, 0.0, -np.inf)

    @staticmethod
    def physical(p):
        return {"fraction": p[:, 0]}

    def explain(self, med):
        return (f"{self.channel_id}'s sensitivity is {100 * med['fraction']:+.2g} % off its "
                "metadata value")


class ResponseParameters(Effect):
    """The SUT's natural period and damping off their metadata values on
    the channels ``rows`` (a fit that holds them at nominal: gains only or
    none). Parameters per row: the pendulum's coordinates ``c0_rel`` and
    ``c1_rel`` (:mod:`bayescal.core.response.pendulum`; 1 at the metadata values), with
    the sensor's stated prior: log-normal period and damping around their
    metadata values with the tolerances of ``priors`` (the main fit's prior
    when it fits them, ``--fit-response all``). The amplitude at the
    normalisation frequency is kept (the gain, free or held, carries it).
    All rows at once: one name for one cause (a sensor whose metadata give
    the wrong pendulum)."""

    name = "response_parameters"
    #: The parameters' value with no effect (the metadata's pendulum).
    null = 1.0

    def __init__(self, rows, families, channel_ids, priors=None):
        from ..core.priors import Priors

        self.rows = list(rows)
        self.families = list(families)
        self.channel_ids = list(channel_ids)
        pr = priors if priors is not None else Priors()
        self.tolerances = (pr.period_tolerance, pr.damping_tolerance)
        self.param_names = tuple(f"{c.split('.')[-1]}:{n}" for c in self.channel_ids
                                 for n in pendulum.NAMES)
        self._cache = (None, None)

    def grid(self, steps):
        """Starting points in the effect's coordinates, one row per ``(log
        period ratio, damping offset)`` in ``steps`` (every channel alike)."""
        out = []
        for a, b in steps:
            row = []
            for fam in self.families:
                row += [float(x) for x in pendulum.from_physical(
                    fam.period_s * np.exp(a), fam.damping + b, fam.period_s, fam.damping)]
            out.append(row)
        return np.array(out)

    def _inverses(self, f):
        if self._cache[0] is not f:
            self._cache = (f, [fam.inverse_ratio_at(f) for fam in self.families])
        return self._cache[1]

    def _physical(self, p, k):
        fam = self.families[k]
        with np.errstate(invalid="ignore", divide="ignore"):
            return pendulum.to_physical(p[:, 2 * k], p[:, 2 * k + 1], fam.period_s, fam.damping)

    def factor(self, f, p):
        out = np.empty((p.shape[0], len(self.rows), np.size(f)), dtype=complex)
        for k, (fam, inv) in enumerate(zip(self.families, self._inverses(f))):
            period, damping = self._physical(p, k)
            with np.errstate(all="ignore"):
                out[:, k] = inv(period, damping, np.full(p.shape[0], fam.gain))
        return out

    def log_prior(self, p):
        return sum(pendulum.log_prior(p[:, 2 * k], p[:, 2 * k + 1], *self.tolerances)
                   for k in range(len(self.rows)))

    def prior_residual(self, p):
        """The prior's least-squares rows ``(r, J)`` at ``p`` (n_params,)
        (:func:`bayescal.core.response.pendulum.prior_residual` per channel)."""
        n = len(self.rows)
        r, jac = np.zeros(2 * n), np.zeros((2 * n, 2 * n))
        for k in range(n):
            rk, jk = pendulum.prior_residual(p[2 * k], p[2 * k + 1], *self.tolerances)
            r[2 * k:2 * k + 2], jac[2 * k:2 * k + 2, 2 * k:2 * k + 2] = rk, jk
        return r, jac

    def prior_sensitivity(self, fisher, theta, sl):
        """:func:`bayescal.core.response.pendulum.prior_sensitivity` of each
        channel's period, damping and damping/period: ``fisher`` the
        likelihood's information of the whole model at ``theta``, ``sl`` the
        effect's slice in it."""
        blocks = {cid: (sl.start + 2 * k, sl.start + 2 * k + 1)
                  for k, cid in enumerate(self.channel_ids)}
        return pendulum.prior_sensitivity(fisher, theta, blocks, *self.tolerances)

    def physical(self, p):
        out = {}
        for k, cid in enumerate(self.channel_ids):
            period, damping = self._physical(p, k)
            out[f"period_s:{cid}"] = period
            out[f"damping:{cid}"] = damping
            out[f"damping_over_period:{cid}"] = pendulum.damping_over_period(period, damping)
        return out

    def nominal(self):
        """The metadata values, keyed as :meth:`physical`."""
        out = {}
        for fam, cid in zip(self.families, self.channel_ids):
            out[f"period_s:{cid}"] = fam.period_s
            out[f"damping:{cid}"] = fam.damping
            out[f"damping_over_period:{cid}"] = float(pendulum.damping_over_period(
                fam.period_s, fam.damping))
        return out

    def explain(self, med, set_by_prior=None):
        """``med``: medians of what the data measure (:func:`measured`)."""
        parts = []
        nom = self.nominal()
        for cid in self.channel_ids:
            said = []
            for name, unit, fmt in (("period_s", " s", ".4g"), ("damping", "", ".3g"),
                                    ("damping_over_period", " 1/s", ".3g")):
                key = f"{name}:{cid}"
                if key in med:
                    label = {"period_s": "period", "damping_over_period": "damping/period"}.get(
                        name, name)
                    said.append(f"{label} {med[key]:{fmt}}{unit} (metadata {nom[key]:{fmt}})")
            parts.append(f"{cid} " + (", ".join(said) if said else "not measured apart from "
                                      "its prior"))
        text = ("the SUT's natural period and damping differ from its metadata: "
                + "; ".join(parts))
        if set_by_prior:
            tail = any("tail" in e.get("reason", "") for e in set_by_prior.values())
            text += ("; the period and the damping apart are set by the sensor's prior, not "
                     "measured" + (" (the data put them in its tail: a wider "
                                   "--period-tolerance and --damping-tolerance lets the data "
                                   "decide)" if tail else ""))
        return text + "; fit them with --fit-response all"


def measured(params, sensitivity):
    """``params`` (physical name -> summary, keys ``<name>:<channel>``)
    without the values the prior sets (``sensitivity``:
    :meth:`ResponseParameters.prior_sensitivity`), and without
    damping/period where the period and the damping are both measured (it
    adds nothing then). Returns (kept, the ``set_by_prior`` entries)."""
    sbp = pendulum.set_by_prior_entries(sensitivity)
    out = {}
    for key, v in params.items():
        name, cid = key.split(":", 1)
        if f"{cid}:{name}" in sbp:
            continue
        if name == "damping_over_period" and not any(
                f"{cid}:{n}" in sbp for n in ("period_s", "damping")):
            continue
        out[key] = v
    return out, sbp


# --- signatures -------------------------------------------------------------

def _wls_slope(x, y, w):
    """Weighted least-squares slope through the origin and its R^2-like fit quality."""
    slope = np.sum(w * x * y) / np.sum(w * x * x)
    resid = np.sum(w * (y - slope * x) ** 2)
    total = np.sum(w * y * y) + 1e-30
    return slope, 1.0 - resid / total


def signatures(freqs_b, q, weight):
    """Score each response-side candidate from the per-band ratio ``q``
    (B, n_u) and per-band weights (B, n_u) (inverse variance of log q).

    Returns a dict name -> {"score": 0..1, "start": parameter guess, ...}.
    The score is how well the pattern matches (fit quality of the
    signature's shape); the likelihood comparison decides.
    """
    logq = np.log(np.where(np.abs(q) > 0, q, 1.0))
    amp, phase = logq.real, np.unwrap(logq.imag, axis=0)
    f = np.broadcast_to(freqs_b[:, None], q.shape)
    out = {}
    # timing: common phase slope on all channels
    slope, fit = _wls_slope(f.ravel(), phase.ravel(), weight.ravel())
    out["timing_offset"] = {"score": float(max(fit, 0)), "start": float(-slope / (2 * np.pi))}
    # extra pole: log-amplitude change with f^2 at low f x, phase ~ -f x
    mean_amp = np.average(amp, axis=1, weights=weight)
    mean_ph = np.average(phase, axis=1, weights=weight)
    wb = weight.sum(axis=1)
    trend = np.polyfit(np.log(freqs_b), mean_amp, 1, w=np.sqrt(wb))[0]
    pole_fit = float(max(_wls_slope(freqs_b, mean_ph, wb)[1], 0))
    out["extra_pole:sut"] = {"score": pole_fit * float(trend < 0), "amplitude_trend": float(trend)}
    out["extra_pole:ref"] = {"score": pole_fit * float(trend > 0), "amplitude_trend": float(trend)}
    # gain: per channel, flat amplitude offset with little phase
    for i in range(q.shape[1]):
        a = np.average(amp[:, i], weights=weight[:, i])
        spread = np.sqrt(np.average((amp[:, i] - a) ** 2, weights=weight[:, i]))
        out[f"gain_error:{i}"] = {"score": float(abs(a) / (abs(a) + spread + 1e-12)),
                                  "start": float(np.exp(a) - 1)}
    return out


def _drift_fit(t, tau, w):
    """Weighted regression of ``tau`` on ``t``: (slope, mean of ``tau``); ``t``
    is centred here, so that a jackknife's subsets are fitted as whole sets."""
    a = np.average(tau, weights=w)
    tc = t - np.average(t, weights=w)
    return np.sum(w * tc * (tau - a)) / np.sum(w * tc * tc), a


def drift_signature(times_s, tau_k, weight_k, blocks=10):
    """Per-segment timing ``tau_k`` (s) against segment time: the weighted
    regression slope in ppm, its standard error from a delete-one-block
    jackknife over ``blocks`` contiguous blocks of segments (neighbouring
    segments overlap and share slow noise, so the regression's own error
    is too small), and the t-statistic (clock drift when large)."""
    t = np.asarray(times_s, float) - np.mean(times_s)
    tau = np.asarray(tau_k, float)
    w = np.asarray(weight_k, float)
    slope, a = _drift_fit(t, tau, w)
    groups = np.array_split(np.arange(len(t)), min(blocks, len(t)))
    loo = np.array([_drift_fit(np.delete(t, g), np.delete(tau, g), np.delete(w, g))[0]
                    for g in groups])
    g = len(groups)
    se = np.sqrt((g - 1) / g * np.sum((loo - loo.mean()) ** 2))
    return {"ppm": float(slope * 1e6), "sd_ppm": float(se * 1e6),
            "t_stat": float(slope / se) if se > 0 else 0.0, "seconds_mid": float(a)}


def tilt_signature(band_centres, coherence, horizontal):
    """Coherence deficit ``1 - coherence`` (B, n_u) on the horizontals
    against the verticals in the lowest third of the bands, and whether it
    grows toward long periods. Returns dict with ``score`` (ratio of
    deficits), ``rising`` and the channels concerned."""
    horizontal = np.asarray(horizontal, bool)
    deficit = np.clip(1.0 - coherence, 1e-6, 1)
    nb = deficit.shape[0]
    low, high = slice(0, min(2, nb)), slice(max(nb - 3, 0), None)
    if not horizontal.any():
        return {"score": 0.0, "rising": False, "channels": []}
    hz = np.flatnonzero(horizontal)
    h_low = deficit[low][:, hz].mean(axis=0)
    ref_level = (deficit[low][:, ~horizontal].mean() if (~horizontal).any()
                 else deficit[high][:, hz].mean())
    ratio = h_low / ref_level
    rising = h_low > TILT_RATIO * deficit[high][:, hz].mean(axis=0)
    chans = [int(i) for i, r, up, d in zip(hz, ratio, rising, h_low)
             if r > TILT_RATIO and up and d > 0.02]
    return {"score": float(ratio.max()), "rising": bool(rising.any()), "channels": chans,
            "deficit_low": h_low.tolist(), "reference_deficit": float(ref_level)}
