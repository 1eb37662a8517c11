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

    python benchmarks/diagnose_harness.py --runs 60 --out reports/diagnose/harness.json
"""
from __future__ import annotations

import argparse
import os
import sys
import time

import numpy as np

KINDS = ["timing_offset", "clock_drift", "extra_pole", "gain_error", "polarity_reversal",
         "channel_swap", "tilt_noise"]
BAND = (0.02, 3.0)
#: Noise regimes of the runs: (reference coherence, self-noise white in counts).
#: "default": a reference 100x quieter than the SUT's quietest draw (the base
#: model's assumption); "equal": the reference as noisy as the SUT (a huddle of
#: two sensors of one class), noise shaped like the ground; "equal-counts": the
#: same, white in counts (rising in velocity below each sensor's corner, as
#: real self-noise does); "ref10x": the reference 10x quieter than the SUT.
REGIMES = ("default", "equal", "equal-counts", "ref10x")


def regime_kw(regime, coherence):
    """simulate_pair keyword arguments of a noise regime at SUT ``coherence``."""
    if regime == "default":
        return {}
    if regime == "ref10x":
        return {"ref_coherence": 1.0 / (1.0 + 0.1 * (1.0 - coherence) / coherence)}
    if regime in ("equal", "equal-counts"):
        return {"ref_coherence": coherence, "noise_in_counts": regime == "equal-counts"}
    raise ValueError(f"unknown regime {regime!r}; one of {REGIMES}")


def draw(rng, p_clean):
    """(kind, simulate_pair keyword arguments, truth size) for one run."""
    if rng.uniform() < p_clean:
        return "none", {}, None
    kind = KINDS[rng.integers(len(KINDS))]
    sign = rng.choice([-1, 1])
    if kind == "timing_offset":
        s = sign * rng.uniform(0.01, 0.5)
        return kind, {"timing_offset_s": s}, {"seconds": s}
    if kind == "clock_drift":
        p = sign * rng.uniform(5, 100)
        return kind, {"clock_drift_ppm": p}, {"ppm": p}
    if kind == "extra_pole":
        which = str(rng.choice(["sut", "ref"]))
        fc = float(np.exp(rng.uniform(np.log(0.3), np.log(3.0))))
        return kind, {"extra_pole": (which, fc)}, {"corner_hz": fc, "which": which}
    if kind == "gain_error":
        ch, frac = int(rng.integers(3)), sign * rng.uniform(0.01, 0.1)
        resp = [(30.0, 0.707, 750.0)] * 3
        resp[ch] = (30.0, 0.707, 750.0 * (1 + frac))
        return kind, {"sut_response": tuple(resp)}, {"fraction": frac, "row": ch}
    if kind == "polarity_reversal":
        ch = int(rng.integers(3))
        return kind, {"polarity_reversal": ch}, {"row": ch}
    if kind == "channel_swap":
        pair = tuple(sorted(int(x) for x in rng.choice(3, 2, replace=False)))
        return kind, {"channel_swap": pair}, {"rows": list(pair)}
    level = float(np.exp(rng.uniform(np.log(5), np.log(100))))
    return kind, {"tilt_noise": level}, {"level": level}


def run_one(seed, p_clean, regime="default", gain_off=0.0, ref_noise="quiet"):
    """One concealed-effect run; returns its record. ``ref_noise`` is the
    base fit's (the diagnosis's default base is ``quiet``)."""
    import bayescal
    from bayescal.criticism.diagnose import diagnose
    from bayescal.simulate.pair import simulate_pair

    rng = np.random.default_rng(seed)
    kind, kw, truth = draw(rng, p_clean)
    a = rng.uniform(0, 360)
    coherence = float(rng.uniform(0.9, 0.995))
    az, dip = (a, a + 90, 0.0), (0.0, 0.0, -90.0)
    nom_az = tuple(x + rng.uniform(-3, 3) for x in az[:2]) + (0.0,)
    extra = regime_kw(regime, coherence)
    if gain_off and "sut_response" not in kw:
        # each SUT gain off its metadata by up to gain_off (the fit's free gains absorb it);
        # its own generator so the runs' other draws match gain_off = 0
        off = np.random.default_rng([seed, 7]).uniform(-gain_off, gain_off, 3)
        kw = dict(kw, sut_response=tuple((30.0, 0.707, 750.0 * (1 + o)) for o in off))
    sim = simulate_pair(duration=3600, fs=10, seed=seed, coherence=coherence, sut_azimuth=az,
                        sut_dip=dip, nominal_azimuth=nom_az, nominal_dip=dip, **extra, **kw)
    t0 = time.perf_counter()
    from bayescal.io.read import InputError
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
    d = diagnose(post, seed=seed, mcmc=False)
    # the SUT's channel ids in the simulator's row order (the fit's own list,
    # d.ids, drops a channel the coherence gate left out, which shifts rows)
    ids = [tr.id for tr in sim.sut]
    named = d.effects
    names = [e["name"] for e in named]
    rec = {"seed": seed, "truth": kind, "truth_size": truth, "named": names,
           "coherence": coherence, "regime": regime, "gain_off": gain_off,
           "reference_noise_delta_bic": (d.signatures.get("reference_noise") or {}).get("delta_bic"),
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
    ap.add_argument("--out", default="reports/diagnose/harness.json")
    ap.add_argument("--regime", choices=REGIMES, default="default",
                    help="noise regime of the runs (reference coherence, noise shape)")
    ap.add_argument("--gain-off", type=float, default=0.0,
                    help="SUT gains off their metadata by up to this fraction (e.g. 0.03)")
    args = ap.parse_args(argv)
    records = []
    t0 = time.perf_counter()
    for k in range(args.runs):
        rec = run_one(args.first_seed + k, args.p_clean, args.regime, args.gain_off)
        records.append(rec)
        from bayescal.core.posterior import write_json
        write_json(args.out + ".partial", {"runs": records})
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
    os.makedirs(os.path.dirname(args.out) or ".", exist_ok=True)
    from bayescal.core.posterior import write_json
    write_json(args.out, {"runs": records, "table": rows, "right_name_fraction": right,
                   "false_alarm_fraction": false, "markdown": text,
                   "gain_rule_false_alarms": {"channels_excluding_1": g_ex,
                                              "channels_checked": g_ch,
                                              "clean_runs_with_one": g_runs_ex,
                                              "clean_runs": g_runs},
                   "settings": {"duration_s": 3600, "fs": 10, "band_hz": BAND,
                                "coherence": "uniform 0.9-0.995", "p_clean": args.p_clean,
                                "regime": args.regime, "gain_off": args.gain_off}})
    return 0


if __name__ == "__main__":
    sys.exit(main())
