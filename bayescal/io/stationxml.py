"""Corrected metadata out: the SUT's StationXML with the fitted values in.

For every fitted SUT channel, :func:`corrected_inventory` replaces

* ``Azimuth`` and ``Dip`` by the posterior medians, with ``plusError`` /
  ``minusError`` from the 68 % interval (``ci68``); a value held fixed
  (the dip of a channel fitted against a two-channel reference) is left as
  it was;
* when the response was fitted (the gain by default, everything with
  ``--fit-response all``; ``flat`` metadata has only its stage-1 gain
  scaled), the two long-period
  poles of stage 1 by those of the median period and damping, with errors
  from the 68 % interval of the pole samples, stage 1's gain by the median
  gain, the stage's normalization factor so that the gain keeps its meaning
  at the normalization frequency, and the overall sensitivity recalculated;
  the gain's 68 % interval goes into stage 1's Description and the channel's
  comment with the relative gain (fitted / metadata) and its interval
  (StationXML's Gain has no error fields);
* except that a response parameter the data do not constrain ("set by the
  prior", :mod:`bayescal.core.fit.unconstrained`, :mod:`bayescal.core.response.pendulum`)
  keeps its nominal value, and the comment says why; when the data fix
  damping/period but neither separately, the period stays nominal and the
  damping carries the measured damping/period (:func:`written_period_damping`);
* a tilted vertical's azimuth by the azimuth its axis leans toward;
* when the criticism's improved model heads the result, the response as
  the data see it relative to the reference's metadata: each response
  effect of that model written in (a pole missing from the reference's
  metadata as the SUT's equivalent zero, in a stage of its own; a natural
  period and damping as the pendulum poles; a sensitivity error in the
  gain; :mod:`bayescal.io.relative_response`), with a Comment naming the
  reference channel; a clock offset is a time correction of the data, said
  in the comments (and kept in the digitizer stage's delay, which no
  response evaluation applies), never a response change;
* and adds to every changed channel a Comment saying where the values come
  from (:func:`provenance_comment`).

Everything else in the file is left untouched.
"""
from __future__ import annotations

import copy

import numpy as np
from obspy.core.inventory.util import Azimuth, Dip
from obspy.core.util.obspy_types import ComplexWithUncertainties, FloatWithUncertaintiesAndUnit

from ..atomic import atomic_path
from ..errors import InputError


def _errors(entry):
    lo, hi = entry["ci68"]
    med = entry["median"]
    return med, max(med - lo, 0.0), max(hi - med, 0.0)


def find_channel(inventory, cid, time):
    """The channel object (inside ``inventory``) of SEED id ``cid`` active at
    ``time``."""
    net, sta, loc, cha = cid.split(".")
    for n in inventory:
        for s in n:
            for c in s:
                if (n.code, s.code, c.location_code, c.code) == (net, sta, loc, cha) and \
                        (time is None or c.is_active(time=time)):
                    return c
    raise InputError(f"channel {cid} is not in the SUT StationXML")


def pole_with_errors(samples):
    """ComplexWithUncertainties from complex pole samples (median and 68 %)."""
    re = np.percentile(samples.real, [16, 50, 84])
    im = np.percentile(samples.imag, [16, 50, 84])
    return ComplexWithUncertainties(complex(re[1], im[1]),
                                    lower_uncertainty=complex(re[1] - re[0], im[1] - im[0]),
                                    upper_uncertainty=complex(re[2] - re[1], im[2] - im[1]))


def written_period_damping(summary, family):
    """The period and damping the corrected StationXML holds (None, None when
    it keeps the nominal pair): a measured value as measured, one the prior
    sets at nominal, except that when the data fix damping/period
    (:mod:`bayescal.core.response.pendulum`) the damping carries it: the poles' real
    part ``-h w0`` is then the measured one, their modulus the written
    period's."""
    prior = {name for name, e in summary.items() if isinstance(e, dict) and e.get("set_by_prior")}
    period = family.period_s if "period_s" in prior else summary["period_s"]["median"]
    combo = summary.get("damping_over_period")
    if prior & {"period_s", "damping"} and combo and not combo.get("set_by_prior"):
        return period, combo["median"] * period
    if {"period_s", "damping"} <= prior:
        return None, None
    return period, family.damping if "damping" in prior else summary["damping"]["median"]


def write_pendulum(stage, family, period, damping, pole_samples=None):
    """Replace the two long-period poles of the sensor ``stage`` by the
    pendulum pair of ``period`` and ``damping`` (errors from
    ``pole_samples``, (N, 2) complex, when given), and its normalization
    factor so that the stage's gain keeps its meaning at ``family``'s
    normalization frequency."""
    from ..core.response import pendulum_coefficients, pendulum_denominator, pendulum_poles

    hertz = "HERTZ" in str(getattr(stage, "pz_transfer_function_type", "")).upper()
    scale = 1.0 / (2 * np.pi) if hertz else 1.0
    new = pendulum_poles([period], [damping])[0]
    current = [complex(p) / scale for p in stage.poles]
    pair = sorted(np.argsort(np.abs(current))[:2], key=lambda i: -current[i].imag)
    for k, idx in enumerate(pair):
        if pole_samples is None:
            stage.poles[idx] = ComplexWithUncertainties(new[k] * scale)
            continue
        err = pole_with_errors(pole_samples[:, k])
        stage.poles[idx] = ComplexWithUncertainties(
            new[k] * scale, lower_uncertainty=err.lower_uncertainty * scale,
            upper_uncertainty=err.upper_uncertainty * scale)
    sn = 2j * np.pi * family.norm_freq
    a0_ratio = (abs(pendulum_denominator(sn, *pendulum_coefficients(period, damping)))
                / abs(pendulum_denominator(sn, *pendulum_coefficients(family.period_s,
                                                                      family.damping))))
    stage.normalization_factor = float(stage.normalization_factor * a0_ratio)


def update_response(channel, samples, free, summary):
    """Write fitted period, damping, gain into the channel's response."""
    from ..core.response import pendulum_poles, response_family

    resp = channel.response
    stage = resp.response_stages[0]
    fam = response_family(resp)     # a ScaleFamily ('flat') has only its gain fitted
    # a parameter set by the prior keeps its nominal value (the comment says why)
    prior = {name for name, e in summary.items() if isinstance(e, dict) and e.get("set_by_prior")}
    period, damping = written_period_damping(summary, fam) if free == "all" else (None, None)
    if period is not None:
        write_pendulum(stage, fam, period, damping,
                       pendulum_poles(samples[:, 0], samples[:, 1]))
    if "gain" in prior:
        if free != "all" or period is None:
            return                          # nothing fitted is written: response untouched
        gain = fam.gain
    else:
        gain = summary["gain"]["median"]
    stage.stage_gain = float(gain)
    if stage.stage_gain_frequency is None:     # a gain ObsPy's evaluation would ignore
        stage.stage_gain_frequency = float(fam.norm_freq)
    g_lo, g_hi = summary["gain"].get("ci68", (np.nan, np.nan))   # none for a gain held
    stage.description = ("stage gain kept at its nominal value: set by the prior, not by the "
                         "data (see the channel's bayescal comment)" if "gain" in prior else
                         f"stage gain fitted by bayescal: {gain:.6g}, 68 % interval "
                         f"[{g_lo:.6g}, {g_hi:.6g}] (StationXML has no field for a gain's "
                         "uncertainty; see also the channel's bayescal comment)")
    recalculate_sensitivity(channel, fam.norm_freq)


def recalculate_sensitivity(channel, norm_freq):
    """The channel's overall sensitivity recalculated at its own frequency
    (``norm_freq`` when it has none) from its response stages."""
    resp = channel.response
    sens = resp.instrument_sensitivity
    freq = sens.frequency if sens is not None and sens.frequency else norm_freq
    if sens is not None and str(sens.input_units).upper() in ("M/S", "M/SEC"):
        # ObsPy's recalculation in numpy (bayescal.core.response.evalresp; no obspy.signal import)
        from ..errors import NotHandled
        from ..core.response import velocity_response
        sens.frequency = float(freq)
        try:
            sens.value = float(abs(velocity_response(resp, [freq])[0]))
            return
        except NotHandled:
            pass
    try:
        resp.recalculate_overall_sensitivity(freq)
    except Exception as exc:   # ObsPy/evalresp cannot evaluate this response
        raise InputError(f"cannot recalculate the overall sensitivity of {channel.code}: "
                         f"{exc}") from None


def corrected_inventory(inventory, posterior, criticism=None):
    """A copy of ``inventory`` with the posterior's fitted values written in
    (see the module docstring). ``criticism``: when the values are the
    improved model's (result.json's ``criticism``), each channel's comment
    names the effects modelled, a timing offset of the SUT's digitizer
    is added to its last decimating stage's delay, and the headline model's
    response effects are written in as the SUT's response relative to the
    reference's metadata (:mod:`bayescal.io.relative_response`), with a
    Comment that says so and gives a clock effect's time correction."""
    from obspy import UTCDateTime

    from .relative_response import effect_changes

    inv = copy.deepcopy(inventory)
    state = headline_state(posterior) if criticism else None
    changes, missing = effect_changes(state) if state is not None else ({}, [])
    if criticism and state is None and (posterior.meta.headline or {}).get("model") == "improved":
        missing = ["the improved model's response effects (a result read back from its files "
                   "holds no model to evaluate them: write the StationXML where it is fitted)"]
    summary = posterior.summary()
    time = UTCDateTime(posterior.meta.starttime) if posterior.meta.starttime else None
    free = posterior.meta.free_response or "none"
    for cid, entry in summary["channels"].items():
        ch = find_channel(inv, cid, time)
        az, dip = entry["azimuth_deg"], entry["dip_deg"]
        if "ci68" in az and not az.get("undefined"):
            med, lo, hi = _errors(az)
            ch.azimuth = Azimuth(med % 360.0, lower_uncertainty=lo, upper_uncertainty=hi)
        elif "tilt_deg" in entry:   # a tilted vertical: the azimuth its axis leans toward
            med, lo, hi = _errors(_lean_azimuth(posterior, cid))
            ch.azimuth = Azimuth(med % 360.0, lower_uncertainty=lo, upper_uncertainty=hi)
        if "ci68" in dip:
            med, lo, hi = _errors(dip)
            ch.dip = Dip(med, lower_uncertainty=lo, upper_uncertainty=hi)
        if "response" in entry and cid in posterior.response:
            update_response(ch, posterior.response[cid], free, entry["response"])
        ch.comments.append(provenance_comment(posterior, entry))
        if criticism:
            ch.comments.append(criticism_comment(ch, cid, criticism))
            ch.comments.append(_relative(ch, cid, changes.get(cid, []), missing, posterior))
    return inv


def headline_state(posterior):
    """The live fit of the model heading ``posterior`` (its improved
    model's when ``meta.headline`` says so), or None when read from disk."""
    improved = getattr(posterior, "improved", None)
    if (posterior.meta.headline or {}).get("model") == "improved" and improved is not None:
        return improved.state
    return posterior.state


def _relative(channel, cid, changes, missing, posterior):
    """Write the headline model's response ``changes`` of channel ``cid``
    (:func:`bayescal.io.relative_response.effect_changes`) into ``channel``
    and return the Comment that says the response is relative to the
    reference's metadata."""
    from ..core.response import response_family
    from .relative_response import relative_comment, write_changes

    curve = posterior.response_curve or {}
    if changes:
        fam = response_family(channel.response)
        write_changes(channel, changes, lambda st, period, damping: write_pendulum(
            st, fam, period, damping))
        recalculate_sensitivity(channel, fam.norm_freq)
    ref = (curve.get("channels", {}).get(cid) or {}).get("reference") or ", ".join(
        posterior.meta.reference or {})
    return relative_comment(changes, ref, missing,
                            (curve.get("time_correction") or {}).get("text"))


def _timing_offset(criticism):
    e = next((e for e in criticism.get("effects", []) if e["name"] == "timing_offset"), None)
    return None if e is None else e["size"]["seconds"]


def criticism_comment(channel, cid, criticism):
    """A Comment naming the effects the improved model adds (and, for a
    digitizer timing offset, writing it into the stage delay and saying that
    the data need the time correction, :func:`clock_note`)."""
    from obspy.core.inventory.util import Comment

    named = [e for e in criticism.get("effects", []) if cid in e.get("channels", [])]
    text = ("Values from the improved model of bayescal's model criticism, which adds: "
            + "; ".join(e["explanation"] for e in named) + ".") if named else (
        "Values from the improved model of bayescal's model criticism.")
    tau = _timing_offset(criticism) if any(e["name"] == "timing_offset" for e in named) else None
    if tau is not None:
        stage = _decimating_stage(channel)
        if stage is not None:
            stage.decimation_delay = FloatWithUncertaintiesAndUnit(
                float(stage.decimation_delay or 0.0) + tau["median"], unit="SECONDS")
            lo, hi = tau.get("ci95", (np.nan, np.nan))
            text += (f" The timing offset {tau['median']:.6g} s (95 % [{lo:.6g}, {hi:.6g}]; + = "
                     f"the SUT's samples late) is added to the delay of response stage "
                     f"{stage.stage_sequence_number}; its correction is unchanged (the recordings "
                     "still carry the offset).")
        else:
            text += (f" The timing offset {tau['median']:.6g} s (+ = the SUT's samples late) has "
                     "no stage with a decimation delay to go in.")
        text += clock_note(tau["median"])
    return Comment(value=text, subject="bayescal criticism")


def clock_note(seconds):
    """What a clock offset of ``seconds`` (+ = the SUT's samples late) asks of
    the user: it is a time correction of the data, which no response
    evaluation applies (ObsPy's evalresp never reads a stage's delay)."""
    return (f" A clock offset is a time correction of the data, not a response change: "
            f"ObsPy's remove_response does not apply a stage delay, so the recordings keep "
            f"the offset until their time stamps are corrected (shift the SUT's start times "
            f"by {-seconds:+.6g} s).")


def _decimating_stage(channel):
    """The last response stage with decimation fields (the digitizer's
    output), or None."""
    stages = [st for st in (getattr(channel.response, "response_stages", None) or [])
              if getattr(st, "decimation_input_sample_rate", None) is not None]
    return stages[-1] if stages else None


def _lean_azimuth(posterior, cid):
    """Interval summary of the SEED azimuth of a near-vertical channel's axis
    (the direction of its horizontal part), unwrapped around its mean."""
    from ..core.orientation import azimuth_dip, unwrap_azimuths
    from ..core.posterior import interval_summary

    az, _ = azimuth_dip(posterior.vectors[:, posterior.channel_ids.index(cid)])
    return interval_summary(unwrap_azimuths(az))


def prior_text(response, nominal=None):
    """What a StationXML comment says of the response values the prior sets
    (``response``: name -> summary entry with ``set_by_prior``, ``reason``;
    ``nominal``: name -> nominal value): kept at nominal, or, for a damping
    when the data fix damping/period, carried by the written damping."""
    text = ""
    combo = response.get("damping_over_period")
    for name, e in response.items():
        if not (isinstance(e, dict) and e.get("set_by_prior")) or name == "damping_over_period":
            continue
        if name == "damping" and combo and not combo.get("set_by_prior"):
            lo95, hi95 = combo["ci95"]
            text += (f" damping set by the prior, not measured; the data fix damping/period = "
                     f"{combo['median']:.5g} 1/s (95 % [{lo95:.5g}, {hi95:.5g}]), which the "
                     "written damping carries with the written period.")
        else:
            value = (nominal or {}).get(name, e.get("median"))
            text += (f" {name} kept at its nominal value {value:.6g}: set by the prior, "
                     f"not by the data ({e['reason']}).")
    return text


def provenance_comment(posterior, entry):
    """A StationXML Comment saying where the changed values come from:
    reference, band, data window, date, bayescal version, the meaning of the
    errors, and the fitted gain with its interval (StationXML has no place
    for a gain's uncertainty)."""
    from obspy import UTCDateTime
    from obspy.core.inventory.util import Comment

    from ..version import __version__

    meta = posterior.meta
    ref = ", ".join(meta.reference or {}) or "unknown reference"
    lo, hi = meta.band_hz if meta.band_hz is not None else [np.nan, np.nan]
    start = meta.starttime if meta.starttime is not None else "?"
    dur = meta.duration_s
    end = str(UTCDateTime(start) + dur) if dur and start != "?" else "?"
    text = (f"Azimuth/dip{' and response' if 'response' in entry else ''} fitted by bayescal "
            f"{__version__} on {UTCDateTime.now().strftime('%Y-%m-%d')} against {ref}, band "
            f"{lo:.4g}-{hi:.4g} Hz, data {start} - {end}; plusError/minusError are 68 % "
            "credible intervals (16-84 % quantiles).")
    if meta.assumption:
        text += f" Assumed: {meta.assumption}."
    prior = {n: e for n, e in entry.get("response", {}).items() if e.get("set_by_prior")}
    text += prior_text(entry.get("response", {}), entry.get("nominal"))
    gain = entry.get("response", {}).get("gain")
    if gain and "gain" not in prior:
        g_lo, g_hi = gain["ci68"]
        text += (f" Stage 1 gain and instrument sensitivity carry the median gain "
                 f"{gain['median']:.6g}, 68 % interval [{g_lo:.6g}, {g_hi:.6g}] "
                 f"(95 % [{gain['ci95'][0]:.6g}, {gain['ci95'][1]:.6g}]).")
        rel = entry["response"].get("relative_gain")
        if rel and "ci68" in rel:
            text += (f" Relative gain (fitted / metadata) {rel['median']:.5f}, 68 % interval "
                     f"[{rel['ci68'][0]:.5f}, {rel['ci68'][1]:.5f}].")
    return Comment(value=text, subject="bayescal provenance")


def write_corrected(inventory, posterior, path, criticism=None):
    """Write :func:`corrected_inventory` as StationXML to ``path``
    (atomically: temporary name, then rename). Returns ``path``."""
    inv = corrected_inventory(inventory, posterior, criticism)
    with atomic_path(path) as tmp:
        inv.write(tmp, format="STATIONXML", validate=False)
    return path
