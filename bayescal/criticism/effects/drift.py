"""A drifting clock: the SUT's clock offset grows steadily through the
record. Screened by the per-segment timing's trend (:func:`drift_signature`),
fitted on the per-time-block likelihood (:class:`ClockDrift`), then carried
to the errors-in-variables model with its rate taken out of the spectra
(:func:`drift_corrected`, :class:`CorrectedDrift`)."""
from __future__ import annotations

from dataclasses import replace

import numpy as np

from .base import CriticismEffect
from .timing import TimingOffset


class ClockDrift(CriticismEffect):
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
