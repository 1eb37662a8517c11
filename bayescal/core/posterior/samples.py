"""Posterior samples and what users read from them: per-channel azimuth, dip
(or tilt) and response summaries with credible intervals, and the
orthogonality of two horizontals, computed once when a
:class:`~bayescal.result.record.Result` is built (written and read by
:mod:`bayescal.result.schema`).

Intervals are equal-tailed: ``ci68`` = [16, 84] %, ``ci90`` = [5, 95] %,
``ci95`` = [2.5, 97.5] % quantiles of the samples. Azimuths are unwrapped
around their circular mean first, so an interval crossing north stays
contiguous (e.g. [-0.4, 0.6]). A near-vertical channel's tilt and dip
intervals come from the credible region of its two lean components instead
(:func:`vertical_summaries`).
"""
from __future__ import annotations

import numpy as np

from ...result.meta import by_channel
from ..response.pendulum import damping_over_period
from ..orientation.geometry import (NEAR_VERTICAL_DIP_DEG, azimuth_dip, tilt_components,
                                    tilt_from_vertical, unwrap_azimuths)
from ..orientation.tilt_region import REGION_NOTE, tilt_intervals
from .modes import mark_channel

QUANTILES = {"ci68": (16.0, 84.0), "ci90": (5.0, 95.0), "ci95": (2.5, 97.5)}
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
    ``reference_noise`` meta entry (mode, assumption, who chose it)."""
    chosen = {"default": "the default for this pair", "user": "chosen by the user",
              "diagnose": "chosen by the diagnosis"}.get(meta.get("chosen_by"), "")
    given = meta.get("input", {})
    src = f"; from {given['source']}" if given.get("source") else ""
    return (f"{meta.get('mode')} ({meta.get('assumption', '')}{src}"
            f"{'; ' + chosen if chosen else ''})")


def sampled_azimuth_dip(vectors):
    """(azimuth, dip) sample arrays (N, n_ch) in SEED degrees of sampled axes
    ``vectors`` (N, n_ch, 3); azimuths unwrapped per channel around their
    circular mean."""
    az, dip = azimuth_dip(vectors)
    az = np.stack([unwrap_azimuths(az[:, k]) for k in range(az.shape[1])], axis=1)
    return az, dip


def _orientation_entry(kind, vectors, az, dip, nominal_az):
    """The azimuth, dip (and tilt) entries of one channel's summary."""
    med_dip = float(np.median(dip))
    if kind == "fixed" and abs(med_dip) > NEAR_VERTICAL_DIP_DEG:
        # a vertical fixed to a vertical reference: its azimuth means nothing
        return {"azimuth_deg": {**fixed_summary(nominal_az), "median": None,
                                "nominal_deg": nominal_az, "undefined": True,
                                "note": "vertical channel fixed to the reference's axis: "
                                        "azimuth undefined"},
                "dip_deg": fixed_summary(med_dip)}
    if kind == "fixed":
        return {"azimuth_deg": fixed_summary(np.median(az)), "dip_deg": fixed_summary(med_dip)}
    if kind == "circle":
        return {"azimuth_deg": interval_summary(az), "dip_deg": fixed_summary(med_dip)}
    if abs(med_dip) <= NEAR_VERTICAL_DIP_DEG:
        return {"azimuth_deg": interval_summary(az), "dip_deg": interval_summary(dip)}
    tilt, toward = tilt_from_vertical(vectors)
    entry = {"azimuth_deg": {"median": None, "undefined": True,
                             "note": "near-vertical channel: azimuth is not constrained;"
                                     " see tilt_deg (tilt_toward_azimuth_deg: the "
                                     "azimuth its axis leans toward)"}}
    entry["dip_deg"], entry["tilt_deg"] = vertical_summaries(vectors, dip, tilt)
    entry["tilt_toward_azimuth_deg"] = float(np.median(unwrap_azimuths(toward)))
    north, east = tilt_components(vectors)
    entry["tilt_north_deg"] = interval_summary(north)
    entry["tilt_east_deg"] = interval_summary(east)
    return entry


def _response_entry(r, free, set_by_prior):
    """The ``response`` entry of one channel's summary from its (N, 3)
    samples ``r``; ``set_by_prior``: its entries of the meta's
    ``set_by_prior``, by physical name."""
    out = {name: interval_summary(r[:, j]) for j, name in
           enumerate(("period_s", "damping", "gain")) if free == "all" or name == "gain"}
    if free == "all":
        # what a band above the corner fixes (bayescal.core.response.pendulum)
        out["damping_over_period"] = interval_summary(damping_over_period(r[:, 0], r[:, 1]))
    for name, why in set_by_prior.items():
        if name not in out:
            continue
        mark = {"set_by_prior": True, "reason": why["reason"], "action": why["action"]}
        if why["action"] == "held at nominal":
            out[name] = {**fixed_summary(why["nominal"]), **mark}
        else:
            out[name].update(mark)
    return out


def channel_summaries(fit):
    """Every channel's summary (``result.json``'s ``channels``) of ``fit``
    (anything with ``channel_ids``, ``kinds``, ``vectors``, ``response``
    and a :class:`~bayescal.result.meta.Meta` ``meta``)."""
    az, dip = sampled_azimuth_dip(fit.vectors)
    meta = fit.meta
    nominals = meta.nominal or {}
    prior_set = by_channel(meta.set_by_prior)
    out = {}
    for k, cid in enumerate(fit.channel_ids):
        nominal = nominals.get(cid)
        entry = {"kind": fit.kinds[k],
                 **_orientation_entry(fit.kinds[k], fit.vectors[:, k], az[:, k], dip[:, k],
                                      (nominal or {}).get("azimuth_deg", 0.0))}
        if cid in fit.response:
            entry["response"] = _response_entry(fit.response[cid], meta.free_response,
                                                prior_set.get(cid, {}))
        if nominal:
            entry["nominal"] = nominal
        rel = relative_gain(entry.get("response", {}).get("gain"), (nominal or {}).get("gain"),
                            fit.response.get(cid))
        if rel is not None:
            entry["response"]["relative_gain"] = rel
        mark_channel(entry, cid, meta.multimodal)
        out[cid] = entry
    return out


def orthogonality(fit):
    """Angle (degrees) between the axes of the SUT's two fitted
    horizontals, with intervals, keyed ``"A/B"``: ASL's orthogonality
    figure (90 for a perfect sensor). Fixed and flagged ``assumed`` when
    the fit assumed it (one reference channel); empty without two
    horizontals."""
    _, dip = sampled_azimuth_dip(fit.vectors)
    horiz = [k for k in range(len(fit.channel_ids))
             if fit.kinds[k] != "fixed" and abs(np.median(dip[:, k])) < 45.0]
    if len(horiz) != 2:
        return {}
    i, j = horiz
    key = f"{fit.channel_ids[i]}/{fit.channel_ids[j]}"
    cosine = np.clip(np.einsum("nk,nk->n", fit.vectors[:, i], fit.vectors[:, j]), -1, 1)
    if fit.meta.assumption:
        return {key: {**fixed_summary(90.0), "assumed": True}}
    return {key: interval_summary(np.degrees(np.arccos(cosine)))}
