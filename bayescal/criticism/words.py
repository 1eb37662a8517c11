"""The effects the criticism can name, in plain words: each one's label
(how the verdict names it) and what the user can do about it."""
from __future__ import annotations

#: What the user can do about each named effect (the option to pass, or the
#: change to make in the metadata).
ADVICE = {
    "response_parameters": "fit the period and damping with --fit-response all",
    "timing_offset": "correct the SUT's clock, and the time stamps of the recordings it "
                     "made: a clock offset is a time correction of the data (shift each SUT "
                     "trace's start time by {shift:+.3g} s), not a response change; the "
                     "corrected StationXML records it in a stage delay, which ObsPy's "
                     "remove_response does not apply",
    "sut_corner": "correct the SUT's metadata with the long-period corner measured (the "
                  "response relative to the reference's: bayescal.criticism.relative_response)",
    "clock_drift": "check the SUT digitizer's time source (GNSS lock, drifting oscillator)",
    "extra_pole": "add the missing pole to the sensor's metadata (or take responses that "
                  "include its high-frequency poles)",
    "gain_error": "correct the channel's sensitivity in its metadata (or leave the gains free, "
                  "the default, which measures it as the relative gain)",
    "polarity_reversal": "correct the channel's polarity (dip or azimuth sign) in its metadata",
    "channel_swap": "correct the channel names or wiring",
    "tilt_noise": "nothing to correct: it is noise; a quieter site or a longer record "
                  "narrows the long-period intervals",
}


def advice(effect):
    """:data:`ADVICE` for a named effect; a timing offset's with its signed
    time correction (minus the offset: + = the SUT's samples late)."""
    text = ADVICE.get(effect["name"], "")
    if effect["name"] == "timing_offset":
        seconds = effect.get("parameters", {}).get("seconds", {}).get("median")
        text = text.format(shift=-float(seconds)) if seconds is not None else \
            text.replace(" (shift each SUT trace's start time by {shift:+.3g} s)", "")
    return text


def label(effect):
    """An effect's name in plain words."""
    name = effect["name"]
    if name == "extra_pole":
        who = "reference" if effect.get("parameters", {}).get("which") == "ref" else "SUT"
        return f"a pole missing from the {who}'s metadata"
    return {"response_parameters": "the SUT's period and damping off their metadata values",
            "timing_offset": "a timing offset between the digitizers",
            "sut_corner": "the SUT's long-period corner off its metadata",
            "clock_drift": "a drifting SUT clock", "gain_error": "a sensitivity off its metadata",
            "polarity_reversal": "a reversed channel", "channel_swap": "exchanged channels",
            "tilt_noise": "long-period tilt noise"}.get(name, name.replace("_", " "))


def names(effects):
    """The labels of ``effects``, each once, joined as a sentence says them."""
    out = []
    for e in effects:
        lab = label(e)
        if lab not in out:
            out.append(lab)
    return " and ".join(out) if len(out) < 3 else ", ".join(out[:-1]) + " and " + out[-1]


def tried(keys):
    """The effects a search tried (its candidate keys, e.g.
    ``extra_pole:ref#2``), each in plain words once, as a sentence lists
    them; "none" for none."""
    effects = []
    for key in keys:
        name, _, which = key.partition(":")
        effects.append({"name": name, "parameters": {"which": which.split("#")[0]}})
    return names(effects) or "none"


def headline(summary):
    """The line that says a result's estimates are the improved model's
    (``summary``: result.json's content; its ``meta.headline``), with the
    improved model's own model check; None when the fit heads the result."""
    head = (summary.get("meta") or {}).get("headline") or {}
    if head.get("model") != "improved":
        return None
    check = summary.get("adequacy") or {}
    w = check.get("worst")
    text = f"estimates under the improved model ({head.get('label') or 'the named effects'})"
    if w:
        text += (f", whose model check {'passed' if check.get('ok') else 'failed'}: largest "
                 f"standardised misfit {w['misfit']:.3g} in {w['band_hz'][0]:.4g}-"
                 f"{w['band_hz'][1]:.4g} Hz on {w['channel']}")
    return text + "; the fit without it: result.json's rejected_fit"


#: How a posterior that is the improved model's Laplace approximation is
#: named wherever a chain's convergence figures would stand.
LAPLACE = "Laplace approximation (no chain)"


def posterior_text(summary):
    """How the headline's posterior was computed when it is no chain
    (``summary``: result.json's content): :data:`LAPLACE`, with its draws,
    when the improved model fell back to its Gaussian approximation at the
    least-squares point (``meta.approximation``); None for a chain, whose
    convergence figures are printed instead."""
    meta = summary.get("meta") or {}
    if not meta.get("approximation") or meta.get("method"):
        return None
    draws = (meta.get("sampler") or {}).get("draws")
    return (f"{LAPLACE}: the improved model's posterior is a Gaussian at its least-squares "
            "point" + (f", {draws} draws" if draws else "") + "; no ESS or R-hat applies")


def self_noise_text(summary):
    """Whose self-noise and sensor order a result gives when they are not
    the headline model's (``meta.headline.self_noise``), or None."""
    head = (summary.get("meta") or {}).get("headline") or {}
    if head.get("model") != "improved" or not head.get("self_noise"):
        return None
    return f"self-noise and sensor order are {head['self_noise']}"


def round_header(k, kept, keep):
    """The console's line opening round ``k`` of the effects search: what
    the candidates are scored against (the fit with the effects ``kept``
    so far) and the rule (a BIC gain above ``keep``)."""
    against = f"the fit with {' and '.join(kept)}" if kept else "the fit"
    return (f"round {k}: each effect of the catalogue scored against {against} "
            f"(kept when its BIC gain exceeds {keep:g})")


def round_outcome(k, best, tried, keep, most=None):
    """The console's sentence on what round ``k`` kept and why: ``best``
    the candidate it keeps (an entry of ``tried``, with ``effect`` and
    ``delta_bic``) or None, ``keep`` the BIC gain to exceed, ``most`` the
    largest number of effects, given when round ``k`` reaches it."""
    scored = [t for t in tried if t.get("delta_bic") is not None]
    if best is None or best["delta_bic"] <= keep:
        top = max(scored, key=lambda t: t["delta_bic"], default=None)
        return (f"round {k} keeps nothing: no effect improves the fit by a BIC gain above "
                f"{keep:g}" + (f" (the largest: {top['effect']}, {top['delta_bic']:.1f})"
                               if top else "") + "; the search stops")
    others = [t["effect"] for t in scored if t is not best and t["delta_bic"] > keep]
    why = ("the response term the metadata lack, kept before the others" if best.get("first")
           else "the best of the round")
    text = (f"round {k} keeps {best['effect']} (BIC gain {best['delta_bic']:.1f}, {why}); "
            "one effect is kept per round")
    if others:
        text += (f", so {', '.join(others)} (also above {keep:g}) "
                 + ("is" if len(others) == 1 else "are")
                 + f" scored again in round {k + 1} with {best['effect']} in the model")
    return text + (f"; {most} effects at most: the search stops" if most else "")
