"""Posterior samples and what users read from them: per-channel azimuth, dip
(or tilt) and response summaries with credible intervals, convergence
figures, and the ``result.json`` summary as plain JSON values (written and
read by :mod:`bayescal.io.result`).

Intervals are equal-tailed: ``ci68`` = [16, 84] %, ``ci90`` = [5, 95] %,
``ci95`` = [2.5, 97.5] % quantiles of the samples. Azimuths are unwrapped
around their circular mean first, so an interval crossing north stays
contiguous (e.g. [-0.4, 0.6]). A near-vertical channel's tilt and dip
intervals come from the credible region of its two lean components instead
(:func:`vertical_summaries`).
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..checks.adequacy import from_diagnostics
from ..response.pendulum import damping_over_period
from ..orientation.geometry import (NEAR_VERTICAL_DIP_DEG, azimuth_dip, tilt_components,
                                    tilt_from_vertical, unwrap_azimuths)
from ..orientation.tilt_region import REGION_NOTE, tilt_intervals
from .modes import mark_channel

SCHEMA = "bayescal.fit/1"
QUANTILES = {"ci68": (16.0, 84.0), "ci90": (5.0, 95.0), "ci95": (2.5, 97.5)}
#: Response parameter names in model coordinates -> physical names.
PHYSICAL = {"log_gain": "gain"}


def interval_summary(x):
    """Median, mean, sd and equal-tailed 68/90/95 % intervals of samples."""
    x = np.asarray(x, float)
    out = {"median": float(np.median(x)), "mean": float(np.mean(x)), "sd": float(np.std(x))}
    for key, (lo, hi) in QUANTILES.items():
        out[key] = [float(np.percentile(x, lo)), float(np.percentile(x, hi))]
    return out


def vertical_summaries(vectors, dip, tilt):
    """Dip and tilt summaries of a near-vertical channel: medians, means and
    sds of the samples, with 68/90/95 % intervals taken from the credible
    regions of the lean north/east components
    (:func:`bayescal.core.orientation.tilt_region.tilt_intervals`), since an
    equal-tailed interval of a magnitude never holds 0. The tilt's
    ``holds_zero`` says whether the 95 % region holds the vertical, and then
    ``upper95`` is the bound of "tilt < upper95"."""
    t_ci, d_ci, holds = tilt_intervals(vectors, {k: (hi - lo) / 100.0
                                                 for k, (lo, hi) in QUANTILES.items()})
    tilt_entry = {**interval_summary(tilt), **t_ci, "holds_zero": holds["ci95"],
                  "upper95": t_ci["ci95"][1] if holds["ci95"] else None, "interval": REGION_NOTE}
    return {**interval_summary(dip), **d_ci, "interval": REGION_NOTE}, tilt_entry


def fixed_summary(value):
    """Summary of a quantity held fixed (not estimable from the data)."""
    return {"median": float(value), "fixed": True}


def relative_gain(gain_entry, nominal_gain, response_samples):
    """Summary of the relative gain (fitted gain / metadata gain, what a
    relative-gain experiment measures) of one channel, or None when its gain
    was not fitted. A gain held at nominal gives a fixed 1."""
    if gain_entry is None or not nominal_gain:
        return None
    if gain_entry.get("fixed"):
        return {**fixed_summary(gain_entry["median"] / nominal_gain),
                **{k: gain_entry[k] for k in ("set_by_prior", "reason", "action")
                   if k in gain_entry}}
    out = interval_summary(np.asarray(response_samples)[:, 2] / nominal_gain)
    if gain_entry.get("set_by_prior"):
        out.update({k: gain_entry[k] for k in ("set_by_prior", "reason", "action")})
    return out


def describe_treatment(meta):
    """One line on how a fit treated the reference's self-noise, from its
    ``meta["reference_noise"]`` (mode, assumption, who chose it)."""
    chosen = {"default": "the default for this pair", "user": "chosen by the user",
              "diagnose": "chosen by the diagnosis"}.get(meta.get("chosen_by"), "")
    given = meta.get("input", {})
    src = f"; from {given['source']}" if given.get("source") else ""
    return (f"{meta.get('mode')} ({meta.get('assumption', '')}{src}"
            f"{'; ' + chosen if chosen else ''})")


def by_channel(set_by_prior):
    """``{channel id: {physical name: entry}}`` from ``meta["set_by_prior"]``."""
    out = {}
    for name, entry in (set_by_prior or {}).items():
        cid, par = name.rsplit(":", 1)
        out.setdefault(cid, {})[PHYSICAL.get(par, par)] = entry
    return out


@dataclass
class Posterior:
    """Samples of one fit and their physical meaning.

    Attributes
    ----------
    channel_ids : fitted SUT channels (SEED ids), in order.
    kinds : per channel "sphere" (azimuth and dip estimated), "circle"
        (azimuth in the reference's plane) or "fixed" (response only).
    vectors : (N, n_ch, 3) sampled channel axes (NED).
    response : channel id -> (N, 3) period_s, damping, gain samples; only
        for channels whose response was fitted.
    samples, names, log_prob : raw sampler output in model coordinates.
    convergence : tau, ESS, R-hat, acceptance, steps.
    meta : anything the caller wants kept (band, data used, nominal values).

    A posterior just fitted also holds, in memory only (not saved, None when
    read back from disk), what a refit or a model check needs: ``model`` (the
    likelihood it sampled), ``theta_ls`` (its least-squares point),
    ``full_samples`` (the samples in the model's coordinates, held
    parameters included), ``spectra`` (the cross-spectra it was fitted to)
    and ``sut_inventory`` (the SUT's metadata, for the corrected StationXML);
    after a failed model check, ``improved`` the posterior of the criticism's
    improved model.
    """

    channel_ids: list
    kinds: list
    vectors: np.ndarray
    response: dict
    samples: np.ndarray
    names: list
    log_prob: np.ndarray
    convergence: dict
    meta: dict = field(default_factory=dict)
    not_estimable: dict = field(default_factory=dict)
    trace: np.ndarray | None = None
    diagnostics: dict = field(default_factory=dict)
    self_noise: dict = field(default_factory=dict)
    sensor_order: dict = field(default_factory=dict)
    #: the model criticism's findings when the model check failed
    #: (:mod:`bayescal.criticism.verdict`), empty when it did not run
    criticism: dict = field(default_factory=dict)
    model: object = field(default=None, repr=False, compare=False)
    theta_ls: np.ndarray | None = field(default=None, repr=False, compare=False)
    full_samples: np.ndarray | None = field(default=None, repr=False, compare=False)
    spectra: object = field(default=None, repr=False, compare=False)
    sut_inventory: object = field(default=None, repr=False, compare=False)
    improved: object = field(default=None, repr=False, compare=False)

    @property
    def azimuth_dip(self):
        """(azimuth, dip) sample arrays (N, n_ch) in SEED degrees; azimuths
        unwrapped per channel around their circular mean."""
        az, dip = azimuth_dip(self.vectors)
        az = np.stack([unwrap_azimuths(az[:, k]) for k in range(az.shape[1])], axis=1)
        return az, dip

    def channel_summary(self, k):
        cid = self.channel_ids[k]
        az, dip = self.azimuth_dip
        med_dip = float(np.median(dip[:, k]))
        entry = {"kind": self.kinds[k]}
        if self.kinds[k] == "fixed" and abs(med_dip) > NEAR_VERTICAL_DIP_DEG:
            # a vertical fixed to a vertical reference: its azimuth means nothing
            nominal_az = self.meta.get("nominal", {}).get(cid, {}).get("azimuth_deg", 0.0)
            entry["azimuth_deg"] = {**fixed_summary(nominal_az), "median": None,
                                    "nominal_deg": nominal_az, "undefined": True,
                                    "note": "vertical channel fixed to the reference's axis: "
                                            "azimuth undefined"}
            entry["dip_deg"] = fixed_summary(med_dip)
        elif self.kinds[k] == "fixed":
            entry["azimuth_deg"] = fixed_summary(np.median(az[:, k]))
            entry["dip_deg"] = fixed_summary(med_dip)
        elif self.kinds[k] == "circle":
            entry["azimuth_deg"] = interval_summary(az[:, k])
            entry["dip_deg"] = fixed_summary(med_dip)
        elif abs(med_dip) > NEAR_VERTICAL_DIP_DEG:
            tilt, toward = tilt_from_vertical(self.vectors[:, k])
            entry["azimuth_deg"] = {"median": None, "undefined": True,
                                    "note": "near-vertical channel: azimuth is not constrained;"
                                            " see tilt_deg (tilt_toward_azimuth_deg: the "
                                            "azimuth its axis leans toward)"}
            entry["dip_deg"], entry["tilt_deg"] = vertical_summaries(self.vectors[:, k],
                                                                     dip[:, k], tilt)
            entry["tilt_toward_azimuth_deg"] = float(np.median(unwrap_azimuths(toward)))
            north, east = tilt_components(self.vectors[:, k])
            entry["tilt_north_deg"] = interval_summary(north)
            entry["tilt_east_deg"] = interval_summary(east)
        else:
            entry["azimuth_deg"] = interval_summary(az[:, k])
            entry["dip_deg"] = interval_summary(dip[:, k])
        if cid in self.response:
            r = self.response[cid]
            entry["response"] = {name: interval_summary(r[:, j])
                                 for j, name in enumerate(("period_s", "damping", "gain"))
                                 if self.meta.get("free_response") == "all" or name == "gain"}
            if self.meta.get("free_response") == "all":
                # what a band above the corner fixes (bayescal.core.response.pendulum)
                entry["response"]["damping_over_period"] = interval_summary(
                    damping_over_period(r[:, 0], r[:, 1]))
            for name, why in by_channel(self.meta.get("set_by_prior")).get(cid, {}).items():
                if name not in entry["response"]:
                    continue
                mark = {"set_by_prior": True, "reason": why["reason"], "action": why["action"]}
                if why["action"] == "held at nominal":
                    entry["response"][name] = {**fixed_summary(why["nominal"]), **mark}
                else:
                    entry["response"][name].update(mark)
        nominal = self.meta.get("nominal", {}).get(cid)
        if nominal:
            entry["nominal"] = nominal
        rel = relative_gain(entry.get("response", {}).get("gain"), (nominal or {}).get("gain"),
                            self.response.get(cid))
        if rel is not None:
            entry["response"]["relative_gain"] = rel
        mark_channel(entry, cid, self.meta.get("multimodal"))
        return entry

    def orthogonality(self):
        """Angle (degrees) between the axes of the SUT's two fitted
        horizontals, with intervals, keyed ``"A/B"``: ASL's orthogonality
        figure (90 for a perfect sensor). Fixed and flagged ``assumed`` when
        the fit assumed it (one reference channel); empty without two
        horizontals."""
        az, dip = self.azimuth_dip
        horiz = [k for k in range(len(self.channel_ids))
                 if self.kinds[k] != "fixed" and abs(np.median(dip[:, k])) < 45.0]
        if len(horiz) != 2:
            return {}
        i, j = horiz
        key = f"{self.channel_ids[i]}/{self.channel_ids[j]}"
        cosine = np.clip(np.einsum("nk,nk->n", self.vectors[:, i], self.vectors[:, j]), -1, 1)
        if self.meta.get("assumption"):
            return {key: {**fixed_summary(90.0), "assumed": True}}
        return {key: interval_summary(np.degrees(np.arccos(cosine)))}

    def summary(self):
        """The ``result.json`` content (schema ``bayescal.fit/1``): plain
        JSON values (dicts, lists, str, float, int, bool, None)."""
        conv = self.convergence
        return jsonable({
            "schema": SCHEMA,
            "adequacy": from_diagnostics(self.diagnostics),
            "multimodal": self.meta.get("multimodal") or {
                "detected": None, "note": "not searched for this kind of fit"},
            "channels": {cid: self.channel_summary(k) for k, cid in enumerate(self.channel_ids)},
            "not_estimable": self.not_estimable,
            "set_by_prior": {cid: {k: v["reason"] for k, v in e.items()} for cid, e in
                             by_channel(self.meta.get("set_by_prior")).items()},
            "orthogonality_deg": self.orthogonality(),
            **({"self_noise": self.self_noise} if self.self_noise else {}),
            **({"sensor_order": self.sensor_order} if self.sensor_order else {}),
            **({"criticism": self.criticism} if self.criticism else {}),
            "convergence": {"ess_min": float(np.min(conv["ess"])),
                            "tau_max": float(np.max(conv["tau"])),
                            "rhat_max": float(np.max(conv["rhat"])),
                            "n_steps": int(conv["n_steps"]),
                            "n_walkers": int(conv["n_walkers"]),
                            "acceptance": float(conv["acceptance"]),
                            "converged": bool(conv["converged"]),
                            "per_parameter": {n: {"tau": float(t), "ess": float(e), "rhat": float(r)}
                                              for n, t, e, r in zip(self.names, conv["tau"],
                                                                    conv["ess"], conv["rhat"])}},
            "meta": {k: v for k, v in self.meta.items() if k != "multimodal"},
        })


def jsonable(obj):
    """``obj`` as plain JSON values: numpy arrays as lists, numpy scalars as
    Python numbers, non-finite floats as None."""
    if isinstance(obj, dict):
        return {str(k): jsonable(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [jsonable(v) for v in obj]
    if isinstance(obj, np.ndarray):
        return jsonable(obj.tolist())
    if isinstance(obj, (np.floating, float)):
        return float(obj) if np.isfinite(obj) else None
    if isinstance(obj, (np.integer,)):
        return int(obj)
    if isinstance(obj, (np.bool_,)):
        return bool(obj)
    return obj
