"""The SUT's response as the data see it, written into its StationXML: what
the headline model's response effects change in each SUT channel's
response, relative to the reference's metadata
(:func:`effect_changes`), and how it is written (:func:`write_changes`).

A pair sees only the SUT's response over the reference's metadata response
(:mod:`bayescal.pair.response_curve`), so a pole missing from the
reference's metadata is written as the equivalent zero of the SUT's
response; a pole missing from the SUT's as its pole. Each such factor goes
into a poles-and-zeros stage of its own, inserted after the sensor's stage
(unit gain at its normalisation frequency, the effect's own), so the
sensor's stage and the digitizer's stages stay as their metadata give them;
a natural period and damping off their metadata values replace the
sensor's pendulum poles; a sensitivity error scales the sensor stage's
gain. A clock effect is not response
(:func:`bayescal.core.model.effect.is_clock`): it is written as a comment
and a time correction of the data, never as a stage.

Every value is the posterior median of the effect's parameters under the
headline model. An effect can give its own change of the SUT's response
with a method ``sut_response(p, row)`` (``p`` its parameters' medians)
returning a :func:`change` dict; the catalogue's extra pole, gain error and
response parameters are translated here by name.
"""
from __future__ import annotations

import numpy as np

#: The Comment subject of the relative-response note.
SUBJECT = "bayescal response relative to the reference"


def change(zeros=(), poles=(), norm_freq=1.0, gain_factor=1.0, pendulum=None, label=""):
    """One effect's change of one channel's response: ``zeros``, ``poles``
    (rad/s) of a stage of their own normalised to 1 at ``norm_freq`` (Hz),
    a factor on the sensor stage's gain, the ``pendulum`` ``(period_s,
    damping)`` replacing the sensor's two long-period poles (or None), and
    its ``label`` in words."""
    return {"zeros": [complex(z) for z in zeros], "poles": [complex(p) for p in poles],
            "norm_freq": float(norm_freq), "gain_factor": float(gain_factor),
            "pendulum": pendulum, "label": label}


def _extra_pole(effect, p, row):
    corner = 1.0 / max(float(p[0]), 1e-12)
    w = -2.0 * np.pi * corner
    if effect.which == "ref":
        return change(zeros=[w], norm_freq=effect.norm_freq,
                      label=f"zero at {corner:.4g} Hz: the pole the reference's metadata lack")
    return change(poles=[w], norm_freq=effect.norm_freq,
                  label=f"pole at {corner:.4g} Hz the SUT's metadata lack")


def _gain_error(effect, p, row):
    return change(gain_factor=1.0 + float(p[0]),
                  label=f"sensitivity {100 * float(p[0]):+.3g} % off its metadata value")


def _response_parameters(effect, p, row):
    k = effect.rows.index(row)
    phys = effect.physical(np.asarray(p, float)[None, :])
    cid = effect.channel_ids[k]
    period, damping = float(phys[f"period_s:{cid}"][0]), float(phys[f"damping:{cid}"][0])
    return change(pendulum=(period, damping),
                  label=f"natural period {period:.5g} s, damping {damping:.4g} (the response "
                        "they make is what the data fix; apart, the sensor's prior may set them: "
                        "result.json's criticism says which)")


_TRANSLATIONS = {"extra_pole": _extra_pole, "gain_error": _gain_error,
                 "response_parameters": _response_parameters}


def effect_changes(state):
    """``(changes, not_written)``: channel id -> the list of
    :func:`change` dicts of the response effects of the fit ``state``'s
    model (posterior medians), and the names of the response effects with
    no known change (neither a ``sut_response`` method nor a translation)."""
    from ..core.model import is_clock

    model = getattr(state, "model", None)
    samples = getattr(state, "full_samples", None)
    if model is None or samples is None or not getattr(model, "effects", None):
        return {}, []
    ids = [b.channel_id for b in model.blocks]
    out, missing = {}, []
    for e, sl in zip(model.effects, model.effect_slices):
        if is_clock(e):
            continue
        p = np.median(samples[:, sl], axis=0)
        own = getattr(e, "sut_response", None)
        fn = (lambda eff, q, row: own(q, row)) if own else _TRANSLATIONS.get(e.name)
        if fn is None:
            missing.append(f"{e.name} (no pole-zero form)")
            continue
        for row in e.rows:
            out.setdefault(ids[row], []).append(fn(e, p, row))
    return out, missing


def relative_stage(c, sequence, units):
    """A poles-and-zeros stage of change ``c`` (unit gain at its
    normalisation frequency; ``units`` = (input, output), the sensor
    stage's output units both)."""
    from obspy.core.inventory.response import PolesZerosResponseStage

    from ..core.response import normalization_factor

    return PolesZerosResponseStage(
        stage_sequence_number=sequence, stage_gain=1.0, stage_gain_frequency=c["norm_freq"],
        input_units=units[0], output_units=units[1],
        pz_transfer_function_type="LAPLACE (RADIANS/SECOND)",
        normalization_frequency=c["norm_freq"], zeros=list(c["zeros"]), poles=list(c["poles"]),
        normalization_factor=float(normalization_factor(c["zeros"], c["poles"], c["norm_freq"])),
        description=f"bayescal: the SUT's response relative to the reference's metadata: "
                    f"{c['label']}")


def write_changes(channel, changes, write_pendulum):
    """Write ``changes`` (:func:`effect_changes`' list of one channel) into
    ``channel``'s response: the pendulum through ``write_pendulum(stage,
    period, damping)``, gain factors on the sensor stage, each pole/zero
    change as a stage after it (later stages renumbered). Returns whether
    anything was written."""
    resp = channel.response
    first = resp.response_stages[0]
    wrote = False
    for c in changes:
        if c["pendulum"] is not None:
            write_pendulum(first, *c["pendulum"])
            wrote = True
        if c["gain_factor"] != 1.0:
            first.stage_gain = float(first.stage_gain * c["gain_factor"])
            wrote = True
    added = [c for c in changes if c["zeros"] or c["poles"]]
    units = (first.output_units, first.output_units)
    for k, c in enumerate(added):
        resp.response_stages.insert(1 + k, relative_stage(c, 2 + k, units))
    for k, st in enumerate(resp.response_stages):
        st.stage_sequence_number = k + 1
    return wrote or bool(added)


def relative_comment(changes, reference, not_written=(), clock_text=None):
    """The Comment saying the response is the SUT's relative to the
    reference's metadata (``reference``: the reference channel's id), what
    was written, what was not, and the time correction a clock effect asks
    (``clock_text``)."""
    from obspy.core.inventory.util import Comment

    text = (f"Response written as the data see it relative to the reference's metadata "
            f"({reference}): a pair of recordings measures only the SUT's response over the "
            "reference's, so this response is the reference's metadata response times that "
            "measured ratio")
    if changes:
        text += "; it carries " + "; ".join(c["label"] for c in changes)
    if not_written:
        text += f"; not written: {', '.join(not_written)}"
    text += "."
    if clock_text:
        text += f" Not response: {clock_text}."
    return Comment(value=text, subject=SUBJECT)
