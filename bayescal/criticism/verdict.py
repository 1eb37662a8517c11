"""The criticism of a fit that failed its model check, in the main path of
``bayescal fit`` and :func:`bayescal.calibrate` (:mod:`bayescal.pair.criticism`): the diagnosis
(:func:`.diagnose.diagnose`, started from the fit's own model, spectra and
least-squares point, not refitted from scratch) within a work budget
(:func:`criticism_budget`: model evaluations, so that the same seed names
the same effects on any machine), and a verdict in plain words, in three
levels:

* ``fits``: the model describes the recordings within their noise;
* ``usable``: it misfits, but modelling the cause moves no estimate by more
  than :data:`MOVE_SD` of its standard deviation: the estimates are usable
  as they are;
* ``improved``: it misfits and modelling the cause moves the estimates:
  the improved model's head the result (:func:`bayescal.pair.choice.choose`:
  the table, result.json's ``channels``, the report and the corrected
  StationXML), the fit's are kept as the rejected fit;
* ``unexplained``: a misfit stays once every candidate has been tried (or
  the budget ran out): where, and what to try.

:func:`criticise` returns a :class:`Criticism`; its ``summary`` is what
``result.json`` keeps under ``criticism``.
"""
from __future__ import annotations

import time

import numpy as np

from . import words
from ..core import progress
from .advice import accepted, band
from .moves import MOVE_SD, half_width, improved_estimates

#: The criticism's budget as ``bayescal fit --diagnose-budget`` states it, in
#: seconds of this rate's work (:func:`criticism_budget`; checked between
#: candidates).
DEFAULT_BUDGET_S = 60.0
#: Model evaluations a second of ``--diagnose-budget`` stands for: about the
#: criticism's own rate on a busy two-core computer (990 to 2100 a second on
#: three simulated 3-channel pairs with a timing offset, off-nominal
#: pendulums and a clock drift, about half the wall time on the CPU), so
#: that the default of 60 costs 30 s to 2 minutes there.
WORK_PER_SECOND = 2000
#: The wall-clock safety net, in multiples of ``--diagnose-budget``: never
#: reached at the budget's normal cost; when it ends the criticism, the
#: output says so.
TIME_LIMIT_FACTOR = 10.0
#: Most steps of the improved model's sampler (beyond it: the Gaussian
#: approximation at the least-squares point, said in its meta).
MAX_STEPS = 5000

#: Why a named effect's size is not a measurement when a misfit stays: its
#: interval is conditional on the improved model, which the recordings reject.
SIZE_NOTE = ("the sizes above are conditional on a model that still misfits the recordings: "
             "their intervals are not measurements (a misfit the model leaves pulls them by "
             "more than their width says)")

#: The same when the improved model's posterior could not be characterised.
SIZE_NOTE_DEGENERATE = ("the sizes above come from an improved model whose posterior could not "
                        "be characterised: their intervals are not measurements")
#: The same when the search ran out of its budget before it could judge them.
SIZE_NOTE_INCOMPLETE = ("the sizes above come from a search that ran out of its budget before "
                        "every candidate was tried: their intervals are not measurements")

class Criticism:
    """What :func:`criticise` found: ``summary`` (JSON-safe, result.json's
    ``criticism``), ``improved`` (the improved model's
    :class:`~bayescal.core.posterior.state.FitState`,
    or None when nothing was added), ``diagnosis`` (the
    :class:`.diagnose.Diagnosis`, or None when it did not run)."""

    def __init__(self, summary, improved=None, diagnosis=None):
        self.summary, self.improved, self.diagnosis = summary, improved, diagnosis

    @property
    def verdict(self):
        return self.summary["verdict"]


def _effect_sizes(effect):
    """{parameter: {median, ci95}} of a named effect (the numbers only)."""
    out = {}
    for k, v in effect.get("parameters", {}).items():
        if isinstance(v, dict) and "median" in v:
            out[k] = {"median": v["median"], **({"ci95": v["ci95"]} if "ci95" in v else {})}
        elif isinstance(v, dict):     # a per-channel table (tilt noise)
            out[k] = v
    return out


def _degenerate(d, post, effects):
    """Why the improved model's posterior cannot be read as a measurement,
    or None: its sampler fell back to the least-squares point itself, or an
    effect's size has an interval of zero width (a posterior that did not
    move; an interval that claims exact knowledge)."""
    if d.final is not post and d.final.meta.posterior_failed:
        return d.final.meta.posterior_failed
    for e in effects:
        for k, v in e["size"].items():
            ci = v.get("ci95") if isinstance(v, dict) else None
            if ci is not None and not ci[1] > ci[0]:
                return f"the interval of its {k.replace('_', ' ')} has no width"
    return None


def _held_response_moves(effect):
    """moved_sd of estimates the fit held at their metadata values (a period
    and damping named as ``response_parameters``): the shift from the
    metadata value in the improved model's own standard deviations."""
    out = {}
    for key, v in effect.get("parameters", {}).items():
        if not isinstance(v, dict) or "ci68" not in v:
            continue
        name, cid = key.split(":", 1)
        sd = half_width(v)
        nominal = effect.get("nominal", {}).get(key)
        if nominal is None or not sd > 0:
            continue
        out.setdefault(cid, {})[name] = {"median": v["median"], "ci95": v["ci95"],
                                         "fit_median": nominal,
                                         "moved_sd": float((v["median"] - nominal) / sd),
                                         "held_by_fit": True}
    return out


def _where(mismatch):
    return "; ".join(f"{m['band_hz'][0]:.3g}-{m['band_hz'][1]:.3g} Hz on "
                     f"{', '.join(m['channels'])}" for m in mismatch)


def criticism_budget(budget_s=DEFAULT_BUDGET_S):
    """The criticism's :class:`bayescal.core.budget.Budget` for a budget
    stated in seconds (``--diagnose-budget``): ``budget_s *``
    :data:`WORK_PER_SECOND` model evaluations, with a time limit of
    :data:`TIME_LIMIT_FACTOR` ``* budget_s`` seconds as a safety net only."""
    from ..core.budget import Budget
    return Budget("criticism", round(float(budget_s) * WORK_PER_SECOND),
                  time_limit_s=TIME_LIMIT_FACTOR * float(budget_s))


def criticise(post, budget_s=DEFAULT_BUDGET_S, seed=0, log=None, mcmc=True, budget=None,
              band_given=False, **sample_kw):
    """Criticise the fit ``post`` (a :class:`~bayescal.core.posterior.state.FitState`,
    with its ``model`` and ``theta_ls``). Returns a :class:`Criticism`.

    ``budget_s``: the work the search for effects and the improved model's
    chain may do, stated in seconds of :data:`WORK_PER_SECOND` model
    evaluations (:func:`criticism_budget`; checked between candidate
    effects; once spent the criticism is incomplete and the verdict is
    ``unexplained``); ``budget`` (a :class:`bayescal.core.budget.Budget`)
    replaces it. ``mcmc``: sample the improved model (else its Laplace
    approximation). ``band_given``: the band was given (``--band``), so
    no narrower one is advised (:mod:`.advice`, whose rules every advice
    passes). ``sample_kw`` go to the sampler."""
    t0 = time.monotonic()
    budget, budget_s = _budget(budget, budget_s)
    free = post.meta.free_response or "none"
    base_sum = post.summary()
    pinned = _pinned_parameters(base_sum)
    if pinned:
        return Criticism(_pinned(pinned, budget_s))
    d = _diagnosed(post, budget, seed=seed, mcmc=mcmc, log=log, sample_kw=sample_kw)
    seconds = time.monotonic() - t0
    named = list(d.effects)
    moves = _moves(d, post, base_sum, named)
    biggest = max((abs(v["moved_sd"]) for c in moves.values() for v in c.values()), default=0.0)
    left = d.after["mismatch"]
    ref = d.signatures.get("reference_noise", {})
    effects = [_effect_entry(e) for e in named]
    names = words.names(named) or ("the reference's own self-noise" if ref.get("kept") else "")
    degenerate = _degenerate(d, post, effects)
    verdict, text, size_note, advice = _verdict(
        d, names=names, degenerate=degenerate, biggest=biggest, budget=budget,
        budget_s=budget_s, free=free, band_given=band_given)
    advice = _all_advice(advice, effects, verdict, getattr(post, "model", None))
    if degenerate:
        moves, biggest = {}, 0.0
    improved = d.final if d.final is not post and not degenerate else None
    # what heads the result (pair.choice.choose), and so the corrected StationXML
    stationxml = "improved model" if verdict == "improved" and improved is not None else "fit"
    conditional = verdict == "unexplained"
    for e in effects:
        e["size_is_measurement"] = not conditional
    summary = {
        "verdict": verdict, "verdict_text": text, "effects": effects,
        "reference_noise_modelled": bool(ref.get("kept")),
        **_misfits(d, post),
        "improved_estimates": moves, "max_moved_sd": float(biggest), "move_threshold_sd": MOVE_SD,
        "unexplained": [{"band_hz": m["band_hz"], "channels": m["channels"],
                         "misfit_max": m["misfit_max"]} for m in left],
        "advice": advice, "stationxml": stationxml,
        **({"size_note": size_note} if conditional and effects else {}),
        **_search_record(d, budget, budget_s, seconds),
        "sentences": d.sentences(),
    }
    return Criticism(summary, improved, d)


def _diagnosed(post, budget, *, seed, mcmc, log, sample_kw):
    """The diagnosis of ``post`` within ``budget``, saying its progress
    (:mod:`bayescal.core.progress`: a line per candidate, one at its end)."""
    from .diagnose import diagnose

    log = log or progress.logger("criticism")
    with budget.active(), progress.stage("criticism", budget) as stage:
        d = diagnose(post, seed=seed, mcmc=mcmc, progress=False, log=log, budget=budget,
                     **_sampler_options(sample_kw))
        stage.result = f"{len(d.tried)} candidate effects tried" + (
            ", BUDGET SPENT" if d.incomplete else "")
    return d


def _all_advice(advice, effects, verdict, model):
    """The verdict's ``advice`` and the named effects' (their advice is for
    effects the verdict stands by; a response to fit always), less any the
    run of ``model`` would refuse (:func:`.advice.accepted`)."""
    advice = advice + [e["advice"] for e in effects if e["advice"] and verdict != "unexplained"
                       or e["name"] == "response_parameters"]
    return accepted(advice, model)


def _budget(budget, budget_s):
    """The criticism's budget and the seconds it stands for: ``budget``
    when given (its seconds for the words), else :func:`criticism_budget`."""
    if budget is None:
        return criticism_budget(budget_s), budget_s
    return budget, budget.limit / WORK_PER_SECOND


def _effect_entry(e):
    """A named effect as the summary lists it: with what the recordings
    cannot tell it from and the evidence that says so, where the diagnosis
    found any (:func:`bayescal.criticism.search.indistinguishable`)."""
    return {"name": e["name"], "channels": e["channels"], "size": _effect_sizes(e),
            "explanation": e["explanation"], "advice": words.advice(e),
            **({"set_by_prior": e["set_by_prior"]} if e.get("set_by_prior") else {}),
            **{k: e[k] for k in ("indistinguishable_from", "evidence") if e.get(k)}}


def check_misfit(state):
    """The largest standardised misfit of ``state`` (a FitState) as its
    model check gives it (:func:`bayescal.core.checks.adequacy.from_diagnostics`:
    per band and SUT channel at the posterior median, under the model's own
    noise model; the worst cell), or None without one."""
    from ..core.checks import from_diagnostics
    worst = from_diagnostics(getattr(state, "diagnostics", None)).get("worst")
    return None if worst is None else float(worst["misfit"])


def _misfits(d, post):
    """The largest standardised misfits before and after, for the summary:
    the fit's and the improved model's, each as its model check gives it
    (:func:`check_misfit`; after = before when nothing was added), and on
    the one scale the search compares effects on (both under the improved
    model's noise model, at the least-squares points)."""
    before = check_misfit(post)
    after = check_misfit(d.final) if d.final is not post else before
    return {"misfit_before": before, "misfit_after": after,
            "misfit_note": "largest standardised misfit over bands and channels, as each "
                           "model's check gives it (the fit's, then the improved model's; "
                           "about 1 is a fit within the noise)",
            "misfit_search": {"before": float(np.max(d.before_common["misfit"])),
                              "after": float(np.max(d.after["misfit"])),
                              "note": "the same, both under the improved model's noise "
                                      "model at the least-squares points: the scale the "
                                      "search compares effects on"}}


def misfit_line(c):
    """The criticism's misfit before -> after: the fit and the improved
    model both judged against the improved model's noise estimate
    (``misfit_search``), which the misfit the effects remove no longer
    inflates, then each model's own check (``misfit_before``,
    ``misfit_after``: a model's own noise estimate takes in part of the
    misfit it leaves, so a fit that misfits by far reads lower there)."""
    own = (f"each model's own check: {_g(c['misfit_before'], 3)} and "
           f"{_g(c['misfit_after'], 3)}")
    s = c.get("misfit_search")
    if not s:
        return (f"  largest standardised misfit {_g(c['misfit_before'], 3)} -> "
                f"{_g(c['misfit_after'], 3)} with it modelled (each model's check; about 1 "
                "is a fit within the noise)")
    return (f"  largest standardised misfit {_g(s['before'], 3)} -> {_g(s['after'], 3)} with "
            f"it modelled (both against the improved model's noise estimate; {own}; about 1 "
            "is a fit within the noise)")


def _pinned_parameters(base_sum):
    """``{channel id: [response parameter, ...]}`` of the parameters the fit
    pinned (gain aside), for the channels with any."""
    pinned = {cid: [k for k, v in e.get("response", {}).items()
                    if k != "relative_gain" and "pinned" in str(v.get("reason", ""))]
              for cid, e in base_sum["channels"].items()}
    return {c: k for c, k in pinned.items() if k}


def _sampler_options(sample_kw):
    """The sampler's options for the improved model from the fit's."""
    sample_kw = dict(sample_kw)
    sample_kw.pop("progress", None)
    # the fit's own options, not the sampler's: the improved model takes the
    # fit's misfit shape from its model (criticism.diagnose)
    sample_kw.pop("misfit_shape", None)
    sample_kw.pop("inflation_floor", None)
    # the improved model's sampler is bounded too: a chain that does not
    # converge in MAX_STEPS falls back to the Gaussian approximation
    sample_kw["max_steps"] = min(int(sample_kw.get("max_steps") or MAX_STEPS), MAX_STEPS)
    return sample_kw


def _moves(d, post, base_sum, named):
    """The estimates that modelling the named effects moves, by channel."""
    moves = {}
    if d.final is not post:
        moves = improved_estimates(base_sum, d.final.summary())
    for e in named:
        if e["name"] == "response_parameters":
            for cid, v in _held_response_moves(e).items():
                moves.setdefault(cid, {}).update(v)
    return moves


def _verdict(d, *, names, degenerate, biggest, budget, budget_s, free, band_given=False):
    """``(verdict, text, size_note, advice)`` of the diagnosis ``d``:
    unexplained (a degenerate improved model, an incomplete search or a
    misfit left), usable (nothing moves by more than :data:`MOVE_SD`) or
    improved."""
    left = d.after["mismatch"]
    advice = []
    size_note = SIZE_NOTE
    if degenerate:
        verdict = "unexplained"
        text = (f"{names or 'an effect'} would explain the misfit, but the improved model's "
                f"posterior could not be characterised ({degenerate}): its estimates and the "
                "sizes are not measurements; the misfit stays unexplained")
        size_note = SIZE_NOTE_DEGENERATE
        if d.incomplete:
            advice.append(f"a larger budget, e.g. --diagnose-budget {4 * budget_s:g}")
    elif d.incomplete:
        size_note = SIZE_NOTE_INCOMPLETE
        verdict = "unexplained"
        spent = (f"time limit ({budget.time_limit_s:g} s, a safety net: its work budget was "
                 "not spent)" if budget.ended_by == "time" else f"budget of {budget_s:g} s")
        text = (f"criticism incomplete: tried {', '.join(d.tried) or 'no candidate'} before its "
                f"{spent} ran out (not tried: "
                f"{', '.join(d.incomplete['not_tried'])}; --diagnose-budget raises it): the "
                f"misfit stays unexplained")
        advice.append(f"a larger budget, e.g. --diagnose-budget {4 * budget_s:g}")
    elif left:
        verdict = "unexplained"
        more, why_no_band = _misfit_advice(d, free, band_given)
        text = (f"the model does not fit the recordings in {_where(left)}"
                + (f", even with {names} modelled" if names else "")
                + f": no effect the criticism knows explains it (tried: {words.tried(d.tried)})"
                + (f"; the mismatch stays unexplained inside the band ({why_no_band})"
                   if why_no_band else "") + "; treat the estimates with caution")
        advice += more
    elif biggest <= MOVE_SD:
        verdict = "usable"
        text = (f"the model misfits the recordings because of {names or 'an effect it leaves out'}"
                f"; modelling it moves no estimate by more than {MOVE_SD:g} of its standard "
                "deviation: the estimates are usable as they are")
    else:
        verdict = "improved"
        text = (f"the model misfits the recordings because of {names}; modelling it moves the "
                f"estimates (by up to {biggest:.2g} standard deviations): the estimates "
                "reported are the improved model's (the fit's are kept as the rejected fit)")
    return verdict, text, size_note, advice


def _misfit_advice(d, free, band_given):
    """What to try when a misfit is left that no known effect explains, and
    why no narrower band is advised (None when one is): ``(advice, why)``."""
    advice = []
    narrower, why = band(d, band_given=band_given)
    if narrower:
        advice.append(narrower)
    if free != "all" and "response_parameters" not in d.tried:
        advice.append("--fit-response all (period and damping fitted)")
    said = d.sentences()
    caveat = said[-1] if said and "third co-located" in said[-1] else None
    if caveat:
        advice.append(caveat)
    return advice, why


def _search_record(d, budget, budget_s, seconds):
    """The search's extent for the summary: complete or not, what it tried
    and named, its budget and time."""
    return {"complete": d.incomplete is None, "tried": d.tried,
            "not_tried": (d.incomplete or {}).get("not_tried", []),
            "not_named": d.dropped, "budget_s": float(budget_s), "seconds": float(seconds),
            "budget": budget.summary(),
            **({"budget_note": budget.note()} if budget.ended_by == "time" else {})}


def _pinned(pinned, budget_s):
    """The verdict when a fitted value sits at its prior's bound: the model
    cannot fit the recordings with it there, and no effect is looked for
    (one would only absorb the misfit the bound makes)."""
    where = [f"the {', '.join(k)} of {c}" for c, k in pinned.items()]
    where = where[0] if len(where) == 1 else ", ".join(where[:-1]) + " and " + where[-1]
    are = "is" if len(pinned) == 1 and len(next(iter(pinned.values()))) == 1 else "are"
    return {"verdict": "unexplained", "effects": [], "complete": True, "tried": [],
            "not_tried": [], "budget_s": float(budget_s), "seconds": 0.0,
            "verdict_text": f"{where} {are} pinned at the bound of the prior, which leaves a "
                            "misfit no missing physics explains: check the value in the "
                            "metadata, and whether --ref and --sut are swapped, before using "
                            "the estimates",
            "advice": ["check the metadata gain, and the order of --ref and --sut"],
            "unexplained": [], "improved_estimates": {}, "stationxml": "fit"}


def check_orientation(post):
    """When the model check passes: a reversed or exchanged channel fits
    (the orientation is fitted freely) but its metadata are wrong. Returns
    the criticism's summary naming it (verdict ``fits``), or None when the
    fitted axes agree with the metadata."""
    from .diagnose import orientation_effects

    t0 = time.monotonic()
    model, th = post.model, post.theta_ls
    ids = [b.channel_id for b in model.blocks]
    named = orientation_effects(post, model, th, ids)
    if not named:
        return None
    effects = [_effect_entry(e) for e in named]       # (no prior sets an orientation)
    return {"verdict": "fits", "verdict_text": "the model fits the recordings, with "
            f"{words.names(named)} that the fitted orientation already holds: the estimates are "
            "usable as they are, and the metadata need correcting (the corrected StationXML "
            "holds the fitted orientation)", "effects": effects, "complete": True,
            "tried": ["polarity_reversal", "channel_swap"], "not_tried": [],
            "advice": accepted([e["advice"] for e in effects], model), "unexplained": [],
            "improved_estimates": {}, "stationxml": "fit", "seconds": time.monotonic() - t0}


def failed(exc):
    """The criticism's summary when it stopped on an error (the fit stands)."""
    return {"verdict": "unexplained", "verdict_text": "the search for the cause of the misfit "
            f"stopped on an error ({type(exc).__name__}: {exc}): the misfit stays unexplained; "
            "treat the estimates with caution", "effects": [], "complete": False,
            "error": f"{type(exc).__name__}: {exc}"}


def _g(x, digits=5):
    """A number for the console (``digits`` significant digits), or "n/a"
    where result.json holds none (a value that was not finite)."""
    return "n/a" if x is None else f"{x:.{digits}g}"


def lines(c):
    """The criticism in plain words for the console and the report, one
    string per line (``c``: a :class:`Criticism`'s summary)."""
    out = [f"verdict: {c['verdict_text']}"]
    if c["verdict"] == "fits" and not c.get("effects"):
        return out
    for e in c.get("effects", []):
        out.append(f"  found: {e['explanation']}")
    if c.get("size_note"):
        out.append(f"  note: {c['size_note']}")
    if "misfit_before" in c and (c.get("effects") or c.get("reference_noise_modelled")):
        out.append(misfit_line(c))
    moved = [(cid, k, v) for cid, d in c.get("improved_estimates", {}).items()
             for k, v in d.items() if k != "relative_gain"]
    big = sorted((m for m in moved if m[2].get("moved_sd") is not None
                  and abs(m[2]["moved_sd"]) > c.get("move_threshold_sd", MOVE_SD)),
                 key=lambda m: -abs(m[2]["moved_sd"]))      # largest first
    if moved:
        out.append(f"  estimates under the improved model that move by more than "
                   f"{c.get('move_threshold_sd', MOVE_SD):g} sd"
                   + (", largest first:" if big else ": none"))
        for cid, k, v in big:
            lo, hi = v.get("ci95") or (None, None)
            out.append(f"    {cid} {k.replace('_deg', '').replace('_s', '')} {_g(v['median'])} "
                       f"[{_g(lo)}, {_g(hi)}] (the fit: {_g(v['fit_median'])}"
                       f"{', held at its metadata value' if v.get('held_by_fit') else ''}; moved "
                       f"{v['moved_sd']:+.2g} sd)")
    if c.get("budget_note"):
        out.append(f"  note: {c['budget_note']}")
    for a in c.get("advice", []):
        out.append(f"  to do: {a}")
    if c.get("stationxml"):
        out.append("  corrected StationXML: holds the estimates of the table above ("
                   + ("the improved model's, the effect named in each channel's comment)"
                      if c["stationxml"] == "improved model" else "the fit's)"))
    return out
