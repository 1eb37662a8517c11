"""Each parameter's window estimates combined into the record's value.

:func:`combine` takes the windows :func:`~bayescal.record.windows.fit_windows`
fitted and, per parameter, fits the wander model
(:func:`~bayescal.record.wander.fit_wander`: the record's value, the wander's
size and time scale) to the windows' medians, their standard deviations
(half the 68 % width) and mid-times; each window's interval for the record's
value is the 2.5 and 97.5 % quantiles of its own samples (scaled about
their median by the common factor, when it is learned) plus draws of the
wander (:func:`~bayescal.record.wander.widen_samples`). Azimuths are taken
within 180 degrees of the windows' circular mean (each weighted by its
inverse variance), so a record near north does not split at 0/360 and a
stray first window does not move the others. An azimuth is reported as
``bayescal fit`` reports one: its median in [0, 360) and its intervals
contiguous about it, so an interval crossing north keeps a negative lower
end (e.g. [-0.3, 0.6]) or an upper end above 360 (e.g. [359.7, 360.4]);
the record's value so, and each window's row of
:meth:`ParameterRecord.rows` so about the window's own median.
"""
from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np


@dataclass(frozen=True)
class ParameterRecord:
    """One parameter over the record: the fitted windows' ``starts``,
    ``ends`` (UTCDateTime), ``medians``, ``ci95`` (n, 2) and ``record_ci95``
    (n, 2, the windows' intervals for the record's value), ``times`` (their
    mid-points in seconds after the first window's start) and the
    :class:`~bayescal.record.wander.WanderFit` ``fit``. An azimuth's
    windows are contiguous about the record's value, whose median is in
    [0, 360) (:meth:`rows`: each window about its own median)."""

    name: str
    starts: list
    ends: list
    medians: np.ndarray
    ci95: np.ndarray
    record_ci95: np.ndarray
    times: np.ndarray
    fit: object

    def summary(self):
        """The record's value, the wander and the windows' intervals, for JSON."""
        return {**self.fit.summary(), "windows": len(self.starts),
                "record_ci95_median_width": float(np.median(np.diff(self.record_ci95)))}

    def rows(self):
        """Per window: ``(start, end, median, ci95, record_ci95)``, an
        azimuth's three turned by whole turns together so its median lies
        in [0, 360) (as the window's own fit reports it)."""
        for i, start in enumerate(self.starts):
            turn = whole_turns(self.name, self.medians[i])
            yield (start, self.ends[i], self.medians[i] + turn, self.ci95[i] + turn,
                   self.record_ci95[i] + turn)


def whole_turns(name, median):
    """What brings an azimuth's ``median`` into [0, 360): a multiple of 360
    degrees (0 for any other parameter)."""
    if not name.endswith(":azimuth_deg"):
        return 0.0
    return -360.0 * float(np.floor(median / 360.0))


def turned(fit, turn):
    """The :class:`~bayescal.record.wander.WanderFit` ``fit`` with the
    record's value, its intervals, the windows' intervals for it and the
    wander's path moved by ``turn`` degrees."""
    if not turn:
        return fit
    mu = {**fit.mu, "median": fit.mu["median"] + turn,
          "ci68": [v + turn for v in fit.mu["ci68"]], "ci95": [v + turn for v in fit.mu["ci95"]]}
    return replace(fit, mu=mu, record=fit.record + turn, path=fit.path + turn)


def _wrapped(name, values, reference):
    """Azimuths within 180 degrees of ``reference``; other parameters as given."""
    if not name.endswith(":azimuth_deg"):
        return values
    return reference + (values - reference + 180.0) % 360.0 - 180.0


def circular_mean(degrees, weights):
    """The weighted circular mean of angles in ``degrees``, in [0, 360)."""
    a = np.radians(degrees)
    return float(np.degrees(np.arctan2(np.sum(weights * np.sin(a)),
                                       np.sum(weights * np.cos(a)))) % 360.0)


def combine_parameter(name, windows, rng, learn_scale=False):
    """The :class:`ParameterRecord` of parameter ``name`` over the fitted
    ``windows`` that estimate it with an interval of some width (at least
    three); ``learn_scale``: as
    :func:`~bayescal.record.wander.fit_wander` takes it."""
    from .wander import fit_wander, widen_samples
    ws = [w for w in windows if w.fitted and name in w.values
          and np.diff(w.values[name]["ci68"])[0] > 0]       # a held value has no width
    raw = np.array([w.values[name]["median"] for w in ws])
    sd = np.array([np.diff(w.values[name]["ci68"])[0] / 2 for w in ws])
    med = _wrapped(name, raw, circular_mean(raw, 1.0 / np.maximum(sd, 1e-12) ** 2))
    ci95 = np.array([w.values[name]["ci95"] for w in ws]) + (med - raw)[:, None]
    t0 = ws[0].start
    times = np.array([(w.start - t0) + 0.5 * (w.end - w.start) for w in ws])
    fit = fit_wander(med, sd, times, learn_scale=learn_scale)
    record = np.array([np.percentile(widen_samples(_wrapped(name, w.samples[name], m),
                                                   fit.tau_grid, fit.scale_tau_weights, rng,
                                                   fit.scale_grid),
                                     [2.5, 97.5]) for w, m in zip(ws, med)])
    turn = whole_turns(name, fit.mu["median"])     # the record's value in [0, 360)
    return ParameterRecord(name=name, starts=[w.start for w in ws], ends=[w.end for w in ws],
                           medians=med + turn, ci95=ci95 + turn, record_ci95=record + turn,
                           times=times, fit=turned(fit, turn))


def combine(windows, seed=0, learn_scale=False):
    """Per parameter estimated in at least three windows (each with an
    interval of some width), its
    :class:`ParameterRecord` (a dict in the windows' parameter order).

    Parameters
    ----------
    windows : list of Window
        From :func:`~bayescal.record.windows.fit_windows`.
    seed : int
        Seed of the wander's draws added to each window's samples.
    learn_scale : bool
        Learn a common factor on the windows' sds over the record
        (:func:`~bayescal.record.wander.fit_wander`; at least 1): for
        windows fitted with the Gaussian likelihood and the record's
        inflation floor (``fit_windows(..., misfit_shape=float("inf"),
        pool_inflation=True)``), whose sds hold their information and no more.
    """
    from .wander import MIN_WINDOWS
    rng = np.random.default_rng(seed)
    names = []
    for w in windows:
        names += [n for n in w.values if n not in names]
    counts = {n: sum(n in w.values and np.diff(w.values[n]["ci68"])[0] > 0
                     for w in windows if w.fitted) for n in names}
    return {n: combine_parameter(n, windows, rng, learn_scale) for n in names
            if counts[n] >= MIN_WINDOWS}
