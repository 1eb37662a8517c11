"""Concealed-effect harness for ``bayescal diagnose``.

Each run draws an effect from the catalogue (or none, with probability
``--p-clean``) with a seed, hides it in a simulated pair (3600 s at 10 Hz,
coherence drawn in 0.9-0.995, random orientation, metadata within 3 degrees of the truth),
runs the base fit and the diagnosis (base by MCMC, final model by its
Laplace approximation for speed), and scores what the tool names:

* right name: the hidden effect is named (extra pole: on the right sensor;
  gain error, polarity: on the right channel; swap: the right pair); a gain
  error also when nothing is named and the fit, whose gains are free by
  default, measures it: the channel's relative gain (fitted / metadata) has
  a 95 % interval that excludes 1 and holds the truth (``measured_as``);
* wrong name: something else is named and the hidden effect is not;
* miss: nothing is named on an effect run;
* false alarm: anything is named on a clean run.

The gain rule has false alarms of its own, which the last line counts apart:
a channel whose true relative gain is 1 (on a clean run, or the other two of
a gain-error run) with a 95 % interval excluding 1 (about 5 % of channels
expected when the intervals are right).

    python validation/studies/diagnose_harness.py --runs 100 --out validation/results/diagnose/harness.json
"""
from __future__ import annotations

import argparse
import os
import sys
import time

import numpy as np

import study_results                          # the sibling module, run as a script

from bayescal.simulate.harness import KINDS, REGIMES, concealed_pair

BAND = (0.02, 3.0)


def run_one(seed, p_clean, regime="default", gain_off=0.0, ref_noise="quiet"):
    """One concealed-effect run; returns its record. ``ref_noise`` is the
    base fit's (the diagnosis's default base is ``quiet``)."""
    import bayescal
    from bayescal.criticism.diagnose import diagnose

    run = concealed_pair(seed, p_clean, regime, gain_off)
    sim, kind, kw, truth, coherence = run.sim, run.kind, run.kw, run.truth, run.coherence
    t0 = time.perf_counter()
    from bayescal.errors import InputError
    try:
        post = bayescal.calibrate(sut=sim.sut, sut_xml=sim.sut_inventory, ref=sim.ref, ref_xml=sim.ref_inventory,
                                  band=BAND, progress=False, seed=seed, min_ess=200, n_tau=20,
                                  ref_noise=ref_noise, diagnose=False)
    except InputError as exc:
        # the fit refuses (e.g. too little coherence when both sensors are noisy):
        # nothing is named, which is neither a detection nor a false alarm
        return {"seed": seed, "truth": kind, "truth_size": truth, "named": [],
                "coherence": coherence, "regime": regime, "gain_off": gain_off,
                "outcome": "refused", "refusal": str(exc),
                "seconds": time.perf_counter() - t0, "unexplained": []}
    d = diagnose(post.state, seed=seed, mcmc=False)
    # the SUT's channel ids in the simulator's row order (the fit's own list,
    # d.ids, drops a channel the coherence gate left out, which shifts rows)
    ids = [tr.id for tr in sim.sut]
    named = d.effects
    names = [e["name"] for e in named]
    rec = {"seed": seed, "truth": kind, "truth_size": truth, "named": names,
           "coherence": coherence, "regime": regime, "gain_off": gain_off,
           "reference_noise_delta_bic": (d.signatures.get("reference_noise") or {}).get("delta_bic"),
           "reference_noise_kept": bool((d.signatures.get("reference_noise") or {}).get("kept")),
           "tilt_delta_bic": (d.signatures.get("tilt_noise") or {}).get("delta_bic"),
           "seconds": time.perf_counter() - t0, "unexplained": d.unexplained(),
           "sentences": d.sentences()}
    hit = None
    for e in named:
        if e["name"] != kind:
            continue
        if kind == "extra_pole" and e["parameters"]["which"] != truth["which"]:
            continue
        if kind in ("gain_error", "polarity_reversal") and e["channels"] != [ids[truth["row"]]]:
            continue
        if kind == "channel_swap" and sorted(e["channels"]) != sorted(ids[r] for r in truth["rows"]):
            continue
        hit = e
    rec["relative_gains"] = relative_gains(post, ids, kw)
    if kind == "gain_error" and hit is None and not names:
        # with the gains fitted (the default) a gain error is no mismatch: the
        # fit measures it as the channel's relative gain (fitted / metadata)
        # found when its 95 % interval excludes 1 (a detection); whether it
        # holds the truth is scored apart, as every recovered size is
        rel = post.summary()["channels"].get(ids[truth["row"]], {}).get(
            "response", {}).get("relative_gain")
        if rel and "ci95" in rel:
            lo, hi = rel["ci95"]
            rec["relative_gain"] = {"truth": 1 + truth["fraction"], "median": rel["median"],
                                    "ci95": [lo, hi]}
            if not lo <= 1.0 <= hi:
                hit = {"parameters": {"fraction": {"median": rel["median"] - 1,
                                                   "ci95": [lo - 1, hi - 1]}}}
                rec["measured_as"] = "relative gain"
    if kind == "none":
        rec["outcome"] = "false alarm" if names else "clean"
    else:
        rec["outcome"] = "right name" if hit else ("wrong name" if names else "miss")
    if hit is not None and truth is not None:
        size = {}
        for k, v in truth.items():
            p = hit["parameters"].get(k)
            if isinstance(p, dict) and "median" in p:
                size[k] = {"truth": v, "median": p["median"], "ci95": p["ci95"],
                           "covered": p["ci95"][0] <= v <= p["ci95"][1]}
        rec["size"] = size
    return rec


def relative_gains(post, ids, kw):
    """Every SUT channel's relative gain (fitted / metadata): truth, median and
    95 % interval, by channel id (the truth from the simulated responses)."""
    chans = post.summary()["channels"]
    resp = kw.get("sut_response") or [(30.0, 0.707, 750.0)] * 3
    out = {}
    for row, cid in enumerate(ids):
        rel = chans.get(cid, {}).get("response", {}).get("relative_gain")
        if rel and "ci95" in rel:
            out[cid] = {"truth": resp[row][2] / 750.0, "median": rel["median"],
                        "ci95": list(rel["ci95"])}
    return out


def gain_false_alarms(records):
    """The gain rule's own false-alarm rate: channels whose true relative gain
    is 1 (every channel of a clean run, the other two of a gain-error run)
    with a 95 % interval that excludes 1. Returns (channels excluding 1,
    channels checked, clean runs with any such channel, clean runs with a
    channel checked)."""
    n_ex = n_ch = runs_ex = runs = 0
    for r in records:
        if r["truth"] not in ("none", "gain_error") or "relative_gains" not in r:
            continue
        ex = [not lo <= 1.0 <= hi for g in r["relative_gains"].values()
              if g["truth"] == 1.0 for lo, hi in [g["ci95"]]]
        n_ex, n_ch = n_ex + sum(ex), n_ch + len(ex)
        if r["truth"] == "none" and ex:     # (with --gain-off no channel's truth is 1)
            runs, runs_ex = runs + 1, runs_ex + any(ex)
    return n_ex, n_ch, runs_ex, runs


def noise_and_leftovers(records):
    """Of the runs the fit accepted: how many had the reference's own
    self-noise named (kept by its BIC test, before any effect is tried),
    how many kept a mismatch the final model leaves unexplained, and each
    run with a name (seed, hidden effect, names, the diagnosis's
    sentences)."""
    done = [r for r in records if r["outcome"] != "refused"]
    return {"accepted": len(done),
            "reference_noise_named": sum(bool(r.get("reference_noise_kept")) for r in done),
            "unexplained": sum(bool(r.get("unexplained")) for r in done),
            "named": [{"seed": r["seed"], "truth": r["truth"], "named": r["named"],
                       "sentences": r.get("sentences", [])} for r in done if r["named"]]}


def table(records):
    """Confusion table: rows = hidden effect, columns = outcomes."""
    cols = ["right name", "wrong name", "miss", "false alarm", "clean", "refused"]
    rows = {}
    for r in records:
        rows.setdefault(r["truth"], dict.fromkeys(cols, 0))[r["outcome"]] += 1
    return cols, rows


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--runs", type=int, default=60)
    ap.add_argument("--p-clean", type=float, default=0.3)
    ap.add_argument("--first-seed", type=int, default=1000)
    ap.add_argument("--out", default="validation/results/diagnose/harness.json")
    ap.add_argument("--regime", choices=REGIMES, default="default",
                    help="noise regime of the runs (reference coherence, noise shape)")
    ap.add_argument("--gain-off", type=float, default=0.0,
                    help="SUT gains off their metadata by up to this fraction (e.g. 0.03)")
    ap.add_argument("--summarise", action="store_true",
                    help="write OUT's noise and leftover counts again from its per-run records")
    args = ap.parse_args(argv)
    if args.summarise:
        doc = study_results.read(args.out)
        doc["noise_and_leftovers"] = noise_and_leftovers(doc["runs"])
        study_results.write(args.out, doc)
        return 0
    records = []
    t0 = time.perf_counter()
    for k in range(args.runs):
        rec = run_one(args.first_seed + k, args.p_clean, args.regime, args.gain_off)
        records.append(rec)
        study_results.checkpoint(args.out, {"runs": records})
        print(f"{k + 1:3d} seed {rec['seed']} {rec['truth']:18s} -> {rec['outcome']:11s} "
              f"{rec['named']} {rec['seconds']:.1f} s", file=sys.stderr, flush=True)
    cols, rows = table(records)
    lines = ["| hidden effect | " + " | ".join(cols) + " |", "|---" * (len(cols) + 1) + "|"]
    for kind in ["none"] + KINDS:
        if kind in rows:
            lines.append(f"| {kind} | " + " | ".join(str(rows[kind][c]) for c in cols) + " |")
    eff = [r for r in records if r["truth"] != "none"]
    clean = [r for r in records if r["truth"] == "none"]
    right = sum(r["outcome"] == "right name" for r in eff) / max(len(eff), 1)
    clean = [r for r in clean if r["outcome"] != "refused"]
    false = sum(r["outcome"] == "false alarm" for r in clean) / max(len(clean), 1)
    cover = [s["covered"] for r in eff for s in r.get("size", {}).values()]
    lines.append("")
    lines.append(f"right name {100 * right:.0f} % of {len(eff)} effect runs; false alarms "
                 f"{100 * false:.0f} % of {len(clean)} clean runs; effect size inside its 95 % "
                 f"interval in {sum(cover)} of {len(cover)} recovered sizes; "
                 f"{time.perf_counter() - t0:.0f} s in all")
    g_ex, g_ch, g_runs_ex, g_runs = gain_false_alarms(records)
    lines.append(f"the gain rule's own false alarms: {g_ex} of {g_ch} channels whose true "
                 f"relative gain is 1 have a 95 % interval excluding 1 ({g_runs_ex} of "
                 f"{g_runs} clean runs have one such channel); not counted above")
    lines.append("")
    lines.append("| hidden effect | parameter | truth | median [95 %] |")
    lines.append("|---|---|---|---|")
    for r in eff:
        for k, s in r.get("size", {}).items():
            lines.append(f"| {r['truth']} | {k} | {s['truth']:.4g} | {s['median']:.4g} "
                         f"[{s['ci95'][0]:.4g}, {s['ci95'][1]:.4g}] |")
    text = "\n".join(lines)
    print(text)
    study_results.write(args.out, {
        "runs": records, "table": rows, "right_name_fraction": right,
        "false_alarm_fraction": false, "markdown": text,
        "gain_rule_false_alarms": {"channels_excluding_1": g_ex, "channels_checked": g_ch,
                                   "clean_runs_with_one": g_runs_ex, "clean_runs": g_runs},
        "noise_and_leftovers": noise_and_leftovers(records),
        "command": " ".join(["python validation/studies/diagnose_harness.py",
                             *(sys.argv[1:] if argv is None else argv)]),
        "settings": {"duration_s": 3600, "fs": 10, "band_hz": BAND,
                     "coherence": "uniform 0.9-0.995", "p_clean": args.p_clean,
                     "regime": args.regime, "gain_off": args.gain_off}})
    study_results.done(args.out)
    return 0


if __name__ == "__main__":
    sys.exit(main())
