"""The response as the data see it: each SUT channel's response relative to
the reference's metadata under the headline model, result.json's
``response_curve``.

A pair of recordings measures the ratio of the two sensors' responses,
counts over counts:

    R(f) = H_sut,fit(f) / H_ref,metadata(f),

the SUT's response under the headline model (its metadata response with the
fitted response parameters and every effect the model adds) over the
reference's metadata response. The reference's true response is not
separable from the SUT's: a pole missing from the reference's metadata
appears here as a zero of the SUT's (a pair never tells them apart). The
denominator is the reference channel whose nominal axis is closest to the
SUT channel's (its ``reference``).

The curve is the model's own: the reciprocal of the likelihood's
deconvolution factor ``H_nom(f) / H_fit(f)`` at its interpolation nodes
(the channel blocks' response families and free parameters times every
effect's factor, as :meth:`bayescal.core.model.likelihood.Model.unpack`
forms it), evaluated by
:func:`bayescal.criticism.fitted_response.model_response`, the one
evaluation of the fitted response, so an effect added to the model enters
the curve as it enters the likelihood. It
is evaluated at about :data:`POINTS_PER_DECADE` of those log-spaced nodes
over the band and for at most :data:`MAX_DRAWS` posterior draws: medians
and equal-tailed 95 % bands of the amplitude and of the phase (radians,
evalresp's sign: ``s = 2 pi i f``), beside the same ratio from the metadata
alone (``H_sut,metadata / H_ref,metadata``).

A clock effect (a timing offset, a clock drift) is not response: its factor
is left out of the curve and reported as a time correction of the data
(``time_correction``). The reference's metadata tolerance is not drawn in:
the curve is relative to the reference's metadata as written.
"""
from __future__ import annotations

import numpy as np

from ..core.model import is_clock

#: Grid density of the curve (points per decade of frequency).
POINTS_PER_DECADE = 20
#: Most posterior draws the curve's quantiles are taken over.
MAX_DRAWS = 2000
#: What the curve is, in result.json's words.
DEFINITION = ("R(f) = H_sut(f) / H_ref,metadata(f), counts over counts: the SUT's response "
              "under the headline model over the reference's metadata response (a pair sees "
              "only this ratio; a pole missing from the reference's metadata shows as a zero "
              "of the SUT's); phase in radians, evalresp's sign (s = 2 pi i f); medians and "
              "95 % bands over the posterior draws; 'metadata': the same ratio from the two "
              "metadata alone; clock effects are left out (time_correction)")


def grid_indices(nodes, per_decade=POINTS_PER_DECADE):
    """Indices into the log-spaced ``nodes`` giving about ``per_decade``
    points per decade, both ends kept."""
    decades = np.log10(nodes[-1] / nodes[0]) if nodes.size > 1 else 0.0
    n = max(2, int(np.ceil(decades * per_decade)) + 1)
    return np.unique(np.round(np.linspace(0, nodes.size - 1, min(n, nodes.size))).astype(int))


def response_factor(model, theta, index=None):
    """``H_fit(f) / H_nom(f)`` of the SUT channels, (W, n_u, Q) at the
    model's nodes ``model.nodes[index]``: the reciprocal of the likelihood's
    deconvolution factor with the clock effects left out
    (:func:`bayescal.criticism.fitted_response.model_response`, the one
    evaluation of the fitted response)."""
    from ..criticism.fitted_response import model_response

    nodes = model.nodes if index is None else model.nodes[index]
    return model_response(model, np.atleast_2d(theta), nodes, timing=False)


def partners(sut_vectors, ref_vectors, ref_ids):
    """Per SUT channel the id of the reference channel whose axis is
    closest to its own (largest ``|cos|`` between the nominal axes)."""
    cos = np.abs(np.asarray(sut_vectors, float) @ np.asarray(ref_vectors, float).T)
    return [ref_ids[j] for j in np.argmax(cos, axis=1)]


def _metadata_response(inventory, cid, time, freqs):
    """A channel's velocity response (counts per m/s) from its metadata."""
    from ..core.response import evaluate_velocity_response

    return evaluate_velocity_response(inventory.get_response(cid, time), freqs)


def _phase(z, reference):
    """Phase (rad) of ``z`` (..., F), unwrapped along frequency around the
    unwrapped phase of ``reference`` (F,) so that every draw lies on the
    same branch."""
    base = np.unwrap(np.angle(reference))
    return base + np.unwrap(np.angle(z / reference), axis=-1)


def _bands(x):
    """Median and 95 % band along the draws (axis 0) of ``x`` (W, F)."""
    lo, med, hi = np.percentile(x, [2.5, 50.0, 97.5], axis=0)
    return {"median": med, "ci95": [lo, hi]}


def channel_curves(factor, h_sut, h_ref):
    """The curve of one SUT channel: ``factor`` (W, F) its ``H_fit / H_nom``
    draws, ``h_sut``, ``h_ref`` (F,) the SUT's and the reference's metadata
    responses. Returns ``{"amplitude", "phase_rad"}`` (medians and 95 %
    bands) and ``"metadata"`` (the metadata ratio's amplitude and phase)."""
    meta = h_sut / h_ref
    draws = factor * meta[None, :]
    return {"amplitude": _bands(np.abs(draws)), "phase_rad": _bands(_phase(draws, meta)),
            "metadata": {"amplitude": np.abs(meta), "phase_rad": np.unwrap(np.angle(meta))}}


def thinned(samples, max_draws=MAX_DRAWS):
    """At most ``max_draws`` rows of ``samples``, evenly spaced."""
    step = max(1, int(np.ceil(len(samples) / max_draws)))
    return samples[::step]


def relative_response(state, data):
    """result.json's ``response_curve`` of the headline fit ``state`` (a
    :class:`~bayescal.core.posterior.state.FitState`) of ``data`` (its
    :class:`~bayescal.pair.preparation.PairData`): see the module docstring.
    Empty when the fit has no model or no samples.

    Returns
    -------
    dict
        ``definition``, ``freq_hz`` (the grid), ``channels`` (SUT id ->
        ``reference``, ``amplitude``, ``phase_rad``, ``metadata``),
        ``effects`` (the headline model's effects the curve holds),
        ``left_out`` (the clock effects it does not) and, when the model
        has a clock effect, ``time_correction`` (:func:`time_correction`).
    """
    from obspy import UTCDateTime

    model, theta = state.model, state.full_samples
    if model is None or theta is None or not hasattr(model, "unpack"):
        return {}
    theta = thinned(theta)
    index = grid_indices(model.nodes)
    freqs = model.nodes[index]
    factor = response_factor(model, theta, index)
    rows = {str(cid): k for k, cid in enumerate(data.fitted.sut_ids)}
    ids = [b.channel_id for b in model.blocks]
    refs = partners([data.sut_vectors[rows[c]] for c in ids], data.ref_vectors,
                    list(data.fitted.ref_ids))
    start = data.meta.get("starttime")
    time = UTCDateTime(start) if start else None
    channels = {}
    for k, (cid, ref) in enumerate(zip(ids, refs)):
        h_sut = _metadata_response(data.sut_inventory, cid, time, freqs)
        h_ref = _metadata_response(data.ref_inventory, ref, time, freqs)
        channels[cid] = {"reference": ref, **channel_curves(factor[:, k], h_sut, h_ref)}
    out = {"definition": DEFINITION, "freq_hz": freqs, "channels": channels,
           "effects": [e.name for e in model.effects if not is_clock(e)],
           "left_out": [e.name for e in model.effects if is_clock(e)]}
    clock = time_correction(model, theta)
    return {**out, **({"time_correction": clock} if clock else {})}


def time_correction(model, theta):
    """The clock effects of ``model`` as a time correction of the SUT's
    data, from the draws ``theta``: ``{"seconds": summary of the SUT's clock
    offset (+ = late; a drift's at mid-record), "ppm": a drift's rate when
    there is one, "text": what to do}``; None without a clock effect."""
    from ..core.posterior import interval_summary

    for e, sl in zip(model.effects, model.effect_slices):
        if not is_clock(e):
            continue
        phys = e.physical(theta[:, sl])
        secs = phys.get("seconds", phys.get("seconds_mid"))
        if secs is None:
            continue
        out = {"effect": e.name, "seconds": interval_summary(secs)}
        if "ppm" in phys:
            out["ppm"] = interval_summary(phys["ppm"])
        out["text"] = time_correction_text(out)
        return out
    return None


def time_correction_text(entry):
    """The sentence of a ``time_correction`` entry: the SUT's clock late
    (or early) by X s, so the data's start time is corrected by -X s."""
    s = entry["seconds"]["median"]
    lo, hi = entry["seconds"]["ci95"]
    text = (f"the SUT's clock is {abs(s):.4g} s {'late' if s >= 0 else 'early'} against the "
            f"reference's (95 % [{lo:.4g}, {hi:.4g}] s, + = late): correct the SUT data's "
            f"start time by {-s:+.4g} s")
    if "ppm" in entry:
        text += (f" at mid-record; the clock drifts {entry['ppm']['median']:+.3g} ppm, so the "
                 "correction changes through the record")
    return text + " (a time correction of the data, not a response)"
