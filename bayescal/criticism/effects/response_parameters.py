"""The SUT's natural period and damping off their metadata values, on a
fit that holds them (gains only or none): the pendulum's two coordinates
per channel with the sensor's stated prior, and what of them the data
measure (:func:`measured`)."""
from __future__ import annotations

import numpy as np

from ...core.response import (NAMES as PENDULUM_NAMES, damping_over_period,
                              from_physical as pendulum_from_physical,
                              log_prior as pendulum_log_prior,
                              prior_residual as pendulum_prior_residual, prior_sensitivity,
                              set_by_prior_entries, to_physical as pendulum_to_physical)
from .base import CriticismEffect


class ResponseParameters(CriticismEffect):
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
        from ...core.priors import Priors

        self.rows = list(rows)
        self.families = list(families)
        self.channel_ids = list(channel_ids)
        pr = priors if priors is not None else Priors()
        self.tolerances = (pr.period_tolerance, pr.damping_tolerance)
        self.param_names = tuple(f"{c.split('.')[-1]}:{n}" for c in self.channel_ids
                                 for n in PENDULUM_NAMES)
        self._cache = (None, None)

    def grid(self, steps):
        """Starting points in the effect's coordinates, one row per ``(log
        period ratio, damping offset)`` in ``steps`` (every channel alike)."""
        out = []
        for a, b in steps:
            row = []
            for fam in self.families:
                row += [float(x) for x in pendulum_from_physical(
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
            return pendulum_to_physical(p[:, 2 * k], p[:, 2 * k + 1], fam.period_s, fam.damping)

    def factor(self, f, p):
        out = np.empty((p.shape[0], len(self.rows), np.size(f)), dtype=complex)
        for k, (fam, inv) in enumerate(zip(self.families, self._inverses(f))):
            period, damping = self._physical(p, k)
            with np.errstate(all="ignore"):
                out[:, k] = inv(period, damping, np.full(p.shape[0], fam.gain))
        return out

    def log_prior(self, p):
        return sum(pendulum_log_prior(p[:, 2 * k], p[:, 2 * k + 1], *self.tolerances)
                   for k in range(len(self.rows)))

    def log_prior_density(self, p):
        """The normalised log prior density at ``p`` (W, n_params): the
        log-normal priors on period and damping, carried to the effect's
        coordinates with their Jacobian (``log_prior`` up to its constant)."""
        pt, dt = self.tolerances
        const = -len(self.rows) * (np.log(2 * np.pi * pt * dt) + np.log(2.0))
        return self.log_prior(p) + const

    def prior_residual(self, p):
        """The prior's least-squares rows ``(r, J)`` at ``p`` (n_params,)
        (:func:`bayescal.core.response.pendulum.prior_residual` per channel)."""
        n = len(self.rows)
        r, jac = np.zeros(2 * n), np.zeros((2 * n, 2 * n))
        for k in range(n):
            rk, jk = pendulum_prior_residual(p[2 * k], p[2 * k + 1], *self.tolerances)
            r[2 * k:2 * k + 2], jac[2 * k:2 * k + 2, 2 * k:2 * k + 2] = rk, jk
        return r, jac

    def prior_sensitivity(self, fisher, theta, sl):
        """:func:`bayescal.core.response.pendulum.prior_sensitivity` of each
        channel's period, damping and damping/period: ``fisher`` the
        likelihood's information of the whole model at ``theta``, ``sl`` the
        effect's slice in it."""
        blocks = {cid: (sl.start + 2 * k, sl.start + 2 * k + 1)
                  for k, cid in enumerate(self.channel_ids)}
        return prior_sensitivity(fisher, theta, blocks, *self.tolerances)

    def physical(self, p):
        out = {}
        for k, cid in enumerate(self.channel_ids):
            period, damping = self._physical(p, k)
            out[f"period_s:{cid}"] = period
            out[f"damping:{cid}"] = damping
            out[f"damping_over_period:{cid}"] = damping_over_period(period, damping)
        return out

    def nominal(self):
        """The metadata values, keyed as :meth:`physical`."""
        out = {}
        for fam, cid in zip(self.families, self.channel_ids):
            out[f"period_s:{cid}"] = fam.period_s
            out[f"damping:{cid}"] = fam.damping
            out[f"damping_over_period:{cid}"] = float(damping_over_period(
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
    sbp = set_by_prior_entries(sensitivity)
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
