"""Proof harness of the criticism in ``bayescal fit``: does it name only what
is there?

Simulated pairs whose noise differs from the simulator's default (a reference
much quieter than the SUT, isotropic field, 1 h): here both sensors have
*equal* self-noise, either shaped like the ground motion or white in counts
(rising in velocity below each sensor's corner), the field is either the
default mix or anisotropic (two plane waves, almost no diffuse part), and the
record lasts 1 to 4 h. Each pair goes through :func:`bayescal.calibrate` with
the product's defaults (gains free, reference noise estimated, the criticism
on when the model check fails); the run's sampler is shortened (``min_ess``
200, 20 autocorrelation times) for time.

Seeds are fixed before any result is seen: seven sets (``SEED_SETS``,
``--seeds``), clean pairs 7000- and single-effect pairs 8000- in the first,
7100- and 9000- in the second, 7200- and 10000- in the third, 7300- and
11000- in the fourth, 7400- and 12000- in the fifth, 7500- and 13000- in
the sixth, 7600- and 14000- in the seventh; the effect of seed ``s`` is
``KINDS[s % len(KINDS)]`` and every other draw comes from
``numpy.random.default_rng(s)``.

Scoring (per run):

* clean pair: "false name" when the criticism names any effect;
* effect pair: "right name" when the hidden effect is named (an extra pole on
  the right sensor, a reversed or re-gained channel on the right channel, a
  swap on the right pair); a gain error also when it is measured as the
  channel's relative gain (fitted / metadata) whose 95 % interval excludes 1
  (the default fit leaves gains free, so a gain error is no misfit);
  "extra names" counts other effects named beside it; "miss" when nothing is
  named, "wrong name" when only others are.
* each recovered size: inside its 95 % interval or not (a period and
  damping: each channel's period and damping, or its damping/period where
  the prior sets those and the effect names damping/period instead),
  counted apart when the criticism says it is not a measurement (its
  verdict "unexplained": the size is conditional on a model the recordings
  still reject); a gain measured as the fit's relative gain is the fit's
  own estimate, a measurement.

    python validation/studies/criticism_harness.py --clean 60 --effects 60 \\
        --seeds third --out validation/results/criticism/harness_third.json

About 10 s a run on an idle core (a clock drift in a 4 h record up to the
criticism's 60 s budget). ``--shard I/N`` runs every N-th pair of (clean,
effect) runs into a checkpoint; ``--merge`` then writes the summary from the
shards' checkpoints.
"""
from __future__ import annotations

import argparse
import json
import os
import sys
import time
import warnings

import numpy as np



class study_results:  # noqa: N801 - the interface of validation/studies/study_results.py
    """Where the output goes: the summary (tracked) at ``--out``, the per-run
    records beside it as ``<name>.runs.json`` (not tracked), checkpoints as
    ``<out>.partial`` while it runs."""

    @staticmethod
    def _dump(path, obj):
        os.makedirs(os.path.dirname(str(path)) or ".", exist_ok=True)
        with open(str(path) + ".tmp", "w") as fh:
            json.dump(obj, fh, indent=1, default=float)
            fh.write("\n")
        os.replace(str(path) + ".tmp", path)

    @staticmethod
    def write(path, doc):
        runs = os.path.splitext(str(path))[0] + ".runs.json"
        study_results._dump(runs, doc)
        summary = {k: v for k, v in doc.items() if k != "runs"}
        summary["runs_file"] = os.path.basename(runs) + " (not tracked: written by the command)"
        study_results._dump(path, summary)

    @staticmethod
    def checkpoint(path, doc):
        study_results._dump(str(path) + ".partial", doc)

    @staticmethod
    def done(path):
        if os.path.exists(str(path) + ".partial"):
            os.remove(str(path) + ".partial")

KINDS = ["timing_offset", "clock_drift", "extra_pole", "gain_error", "polarity_reversal",
         "channel_swap", "tilt_noise", "response_parameters"]
#: Fixed before the results were seen: ``--seeds first``, ``second`` and
#: ``third``, each fixed before any run with it.
SEED_SETS = {"first": (list(range(7000, 7100)), list(range(8000, 8100))),
             "second": (list(range(7100, 7200)), list(range(9000, 9100))),
             "third": (list(range(7200, 7300)), list(range(10000, 10100))),
             "fourth": (list(range(7300, 7400)), list(range(11000, 11100))),
             "fifth": (list(range(7400, 7500)), list(range(12000, 12100))),
             "sixth": (list(range(7500, 7600)), list(range(13000, 13100))),
             "seventh": (list(range(7600, 7700)), list(range(14000, 14100)))}
CLEAN_SEEDS, EFFECT_SEEDS = SEED_SETS["first"]
FS = 10.0
BAND = (0.02, 2.0)
NOMINAL = (30.0, 0.707, 750.0)


def draw(seed, kind):
    """(simulate_pair keywords, truth) of run ``seed`` with effect ``kind``
    (or None)."""
    rng = np.random.default_rng(seed)
    a = rng.uniform(0, 360)
    coherence = float(rng.uniform(0.9, 0.995))
    counts = bool(rng.uniform() < 0.5)
    aniso = bool(rng.uniform() < 0.5)
    duration = float(rng.choice([3600.0, 7200.0, 10800.0, 14400.0]))
    az, dip = (a, a + 90, 0.0), (0.0, 0.0, -90.0)
    nom_az = tuple(x + rng.uniform(-3, 3) for x in az[:2]) + (0.0,)
    kw = dict(duration=duration, fs=FS, seed=seed, coherence=coherence,
              ref_coherence=coherence, noise_in_counts=counts, sut_azimuth=az, sut_dip=dip,
              nominal_azimuth=nom_az, nominal_dip=dip, nominal_response=NOMINAL,
              **({"n_waves": 2, "diffuse": 0.05} if aniso else {}))
    regime = {"noise": "equal, white in counts" if counts else "equal, ground-shaped",
              "field": "anisotropic" if aniso else "default", "duration_s": duration,
              "coherence": coherence}
    sign = rng.choice([-1, 1])
    truth = None
    if kind == "timing_offset":
        s = float(sign * rng.uniform(0.02, 0.5))
        kw["timing_offset_s"], truth = s, {"seconds": s}
    elif kind == "clock_drift":
        p = float(sign * rng.uniform(10, 100))
        kw["clock_drift_ppm"], truth = p, {"ppm": p}
    elif kind == "extra_pole":
        which = str(rng.choice(["sut", "ref"]))
        fc = float(np.exp(rng.uniform(np.log(0.2), np.log(2.0))))
        kw["extra_pole"], truth = (which, fc), {"corner_hz": fc, "which": which}
    elif kind == "gain_error":
        ch, frac = int(rng.integers(3)), float(sign * rng.uniform(0.02, 0.1))
        resp = [NOMINAL] * 3
        resp[ch] = (30.0, 0.707, 750.0 * (1 + frac))
        kw["sut_response"], truth = tuple(resp), {"fraction": frac, "row": ch}
    elif kind == "polarity_reversal":
        ch = int(rng.integers(3))
        kw["polarity_reversal"], truth = ch, {"row": ch}
    elif kind == "channel_swap":
        pair = tuple(sorted(int(x) for x in rng.choice(3, 2, replace=False)))
        kw["channel_swap"], truth = pair, {"rows": list(pair)}
    elif kind == "tilt_noise":
        level = float(np.exp(rng.uniform(np.log(10), np.log(100))))
        kw["tilt_noise"], truth = level, {"level": level}
    elif kind == "response_parameters":
        d = rng.uniform(-0.08, 0.08, 3)
        h = rng.uniform(-0.04, 0.04, 3)
        resp = tuple((30.0 * (1 + a_), 0.707 + b_, 750.0) for a_, b_ in zip(d, h))
        kw["sut_response"] = resp
        truth = {f"period_s:{r}": resp[r][0] for r in range(3)}
        truth.update({f"damping:{r}": resp[r][1] for r in range(3)})
        # named instead of the two where the prior sets them
        truth.update({f"damping_over_period:{r}": resp[r][1] / resp[r][0] for r in range(3)})
    return kw, truth, regime


def _hit(kind, truth, named, ids):
    for e in named:
        if e["name"] != kind:
            continue
        if kind == "extra_pole" and e["size"].get("which") != truth["which"] and \
                e.get("which") != truth["which"]:
            continue
        if kind in ("gain_error", "polarity_reversal") and e["channels"] != [ids[truth["row"]]]:
            continue
        if kind == "channel_swap" and sorted(e["channels"]) != sorted(ids[r]
                                                                      for r in truth["rows"]):
            continue
        return e
    return None


def _sizes(kind, truth, hit, ids):
    out = {}
    measurement = bool(hit.get("size_is_measurement", True)) if hit else True
    if hit is None or truth is None:
        return out
    for k, v in truth.items():
        key = k
        if kind == "response_parameters":
            name, row = k.split(":")
            key = f"{name}:{ids[int(row)]}"
        p = hit["size"].get(key)
        if isinstance(p, dict) and "ci95" in p and isinstance(v, float):
            out[k] = {"truth": v, "median": p["median"], "ci95": p["ci95"],
                      "covered": bool(p["ci95"][0] <= v <= p["ci95"][1]),
                      "measurement": measurement}
    return out


def run_one(seed, kind):
    import bayescal
    from bayescal.errors import InputError
    from bayescal.simulate.pair import simulate_pair

    kw, truth, regime = draw(seed, kind)
    sim = simulate_pair(**kw)
    ids = [tr.id for tr in sim.sut]
    rec = {"seed": seed, "kind": kind or "none", "regime": regime}
    t0 = time.perf_counter()
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            post = bayescal.calibrate(sut=sim.sut, sut_xml=sim.sut_inventory, ref=sim.ref,
                                      ref_xml=sim.ref_inventory, band=BAND, progress=False,
                                      seed=seed, min_ess=200, n_tau=20)
    except InputError as exc:
        rec.update(outcome="refused", note=str(exc)[:200], seconds=time.perf_counter() - t0)
        return rec
    summ = post.summary()
    crit = summ.get("criticism") or {}
    named = crit.get("effects", [])
    # which sensor a named pole is on (kept in the effect's explanation)
    for e in named:
        if e["name"] == "extra_pole":
            e["which"] = "ref" if "reference's response" in e["explanation"] else "sut"
    rec.update(seconds=time.perf_counter() - t0, check_ok=summ["adequacy"].get("ok"),
               verdict=crit.get("verdict", "fits"), named=[e["name"] for e in named],
               criticism_s=crit.get("seconds"), complete=crit.get("complete", True))
    if kind is None:
        rec["outcome"] = "false name" if named else "clean"
        return rec
    hit = _hit(kind, truth, named, ids)
    if hit is None and kind == "gain_error":
        rel = summ["channels"].get(ids[truth["row"]], {}).get("response", {}).get(
            "relative_gain")
        if rel and "ci95" in rel and not rel["ci95"][0] <= 1.0 <= rel["ci95"][1]:
            hit = {"size": {"fraction": {"median": rel["median"] - 1,
                                         "ci95": [rel["ci95"][0] - 1, rel["ci95"][1] - 1]}}}
            rec["measured_as"] = "relative gain"
    rec["extra_names"] = [n for n in rec["named"] if n != kind] if hit else []
    rec["outcome"] = "right name" if hit else ("wrong name" if named else "miss")
    rec["sizes"] = _sizes(kind, truth, hit, ids)
    return rec


def summarise(records):
    clean = [r for r in records if r["kind"] == "none" and r["outcome"] != "refused"]
    eff = [r for r in records if r["kind"] != "none" and r["outcome"] != "refused"]
    sizes = [s for r in eff for s in r.get("sizes", {}).values()]
    cover = [s["covered"] for s in sizes if s.get("measurement", True)]
    conditional = [s["covered"] for s in sizes if not s.get("measurement", True)]
    by_kind = {}
    for r in eff:
        d = by_kind.setdefault(r["kind"], {"runs": 0, "right name": 0, "extra names": 0,
                                           "miss": 0, "wrong name": 0})
        d["runs"] += 1
        d[r["outcome"]] += 1
        d["extra names"] += bool(r.get("extra_names"))
    return {
        "clean_runs": len(clean),
        "clean_false_name": sum(r["outcome"] == "false name" for r in clean),
        "effect_runs": len(eff),
        "effect_right_name": sum(r["outcome"] == "right name" for r in eff),
        "effect_with_extra_names": sum(bool(r.get("extra_names")) for r in eff),
        "sizes_covered": int(sum(cover)), "sizes": len(cover),
        "conditional_sizes_covered": int(sum(conditional)),
        "conditional_sizes": len(conditional),
        "refused": sum(r["outcome"] == "refused" for r in records),
        "criticism_incomplete": sum(not r.get("complete", True) for r in records),
        "by_kind": by_kind,
        "median_seconds": float(np.median([r["seconds"] for r in records])) if records else None,
        "max_seconds": float(max(r["seconds"] for r in records)) if records else None,
        "extra": [what_ran(r, extra_names=r["extra_names"]) for r in eff
                  if r.get("extra_names")],
        "misses": [what_ran(r, named=r["named"]) for r in eff if r["outcome"] != "right name"],
        "sizes_by_noise": sizes_by_noise(eff),
    }


def what_ran(r, **more):
    """The facts of one run a page cites: seed, hidden effect, record
    length (h), noise, field, whether the model check passed, the verdict."""
    g = r["regime"]
    return {"seed": r["seed"], "kind": r["kind"], "hours": g["duration_s"] / 3600,
            "noise": "ground" if "ground" in g["noise"] else "counts", "field": g["field"],
            "check_ok": bool(r.get("check_ok")), "verdict": r.get("verdict"), **more}


def sizes_by_noise(eff):
    """Sizes given as measurements, inside their 95 % intervals / counted,
    split by the noise's shape; and the gain errors measured as the fit's
    relative gain in each."""
    out = {}
    for noise in ("ground", "counts"):
        rs = [r for r in eff if ("ground" in r["regime"]["noise"]) == (noise == "ground")]
        sz = [s for r in rs for s in r.get("sizes", {}).values() if s.get("measurement", True)]
        gains = [s for r in rs if r["kind"] == "gain_error"
                 for s in r.get("sizes", {}).values()]
        out[noise] = {"covered": sum(s["covered"] for s in sz), "sizes": len(sz),
                      "gain_covered": sum(s["covered"] for s in gains), "gains": len(gains)}
    return out


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--clean", type=int, default=60)
    ap.add_argument("--effects", type=int, default=60)
    ap.add_argument("--out", default=None,
                    help="default validation/results/criticism/harness_<seed set>.json")
    ap.add_argument("--seeds", choices=sorted(SEED_SETS), default="first",
                    help="which fixed seed set: first (clean 7000-, effects 8000-), second "
                         "(clean 7100-, effects 9000-), third (clean 7200-, effects 10000-), "
                         "fourth (clean 7300-, effects 11000-), fifth (clean 7400-, effects "
                         "12000-), sixth (clean 7500-, effects 13000-) or seventh (clean "
                         "7600-, effects 14000-)")
    ap.add_argument("--stop-at", default=None,
                    help="UTC time HH:MM after which no new run starts (the summary says so)")
    ap.add_argument("--shard", default=None, metavar="I/N",
                    help="run every N-th pair of (clean, effect) runs starting at I, into the "
                         "checkpoint OUT.I.partial")
    ap.add_argument("--merge", nargs="+", default=None, metavar="CHECKPOINT",
                    help="write OUT from these shard checkpoints (and remove them)")
    ap.add_argument("--summarise", action="store_true",
                    help="write OUT's summary again from its per-run records (OUT's .runs.json)")
    args = ap.parse_args(argv)
    if args.out is None:
        args.out = f"validation/results/criticism/harness_{args.seeds}.json"
    if args.summarise:          # the summary again from the per-run records beside OUT
        runs_file = os.path.splitext(args.out)[0] + ".runs.json"
        doc = json.load(open(runs_file))
        doc["summary"] = summarise(doc["runs"])
        study_results.write(args.out, doc)
        print(json.dumps(doc["summary"], indent=1))
        return 0
    if args.merge:
        parts = [json.load(open(f)) for f in args.merge]
        records = sorted((r for p in parts for r in p["runs"]),
                         key=lambda r: (r["kind"] != "none", r["seed"]))
        out = dict(parts[0], runs=records, summary=summarise(records),
                   done=len(records), planned=sum(p["planned"] for p in parts),
                   stopped_early=any(p["stopped_early"] for p in parts),
                   seconds=max(p["seconds"] for p in parts),
                   command=("python validation/studies/criticism_harness.py --clean 60 "
                            f"--effects 60 --seeds {parts[0]['settings'].get('seed_set', 'first')} "
                            f"--out {args.out} --shard I/{len(parts)} for I in "
                            f"0..{len(parts) - 1}, then --merge"))
        study_results.write(args.out, out)
        for f in args.merge:
            os.remove(f)
        print(json.dumps(out["summary"], indent=1))
        return 0
    clean_seeds, effect_seeds = SEED_SETS[args.seeds]
    plan = []
    for k in range(max(args.clean, args.effects)):      # interleaved: a stop leaves both kinds
        if k < args.clean:
            plan.append((clean_seeds[k], None))
        if k < args.effects:
            s = effect_seeds[k]
            plan.append((s, KINDS[s % len(KINDS)]))
    shard = None
    if args.shard:
        i, n = map(int, args.shard.split("/"))
        plan = [p for j, p in enumerate(plan) if (j // 2) % n == i]   # pairs of clean and effect
        shard = f"{args.out}.{i}"
    records, stopped, out = [], False, {}
    t0 = time.perf_counter()
    for seed, kind in plan:
        if args.stop_at and time.strftime("%H:%M", time.gmtime()) >= args.stop_at:
            stopped = True
            break
        rec = run_one(seed, kind)
        records.append(rec)
        print(f"{len(records):3d} seed {seed} {rec['kind']:20s} -> {rec['outcome']:11s} "
              f"{rec.get('named')} {rec.get('verdict')} {rec['seconds']:.1f} s",
              file=sys.stderr, flush=True)
        out = {"summary": summarise(records), "planned": len(plan), "done": len(records),
               "stopped_early": False, "seconds": time.perf_counter() - t0,
               "settings": {"fs": FS, "band_hz": BAND, "sampler": "min_ess 200, 20 tau",
                            "seed_set": args.seeds,
                            "clean_seeds": clean_seeds[:args.clean],
                            "effect_seeds": effect_seeds[:args.effects], "kinds": KINDS},
               "runs": records}
        study_results.checkpoint(shard or args.out, out)
    out["stopped_early"] = stopped
    if shard:       # the shard's checkpoint stays for --merge
        study_results.checkpoint(shard, out)
    else:
        out["command"] = (f"python validation/studies/criticism_harness.py --clean {args.clean} "
                          f"--effects {args.effects} --seeds {args.seeds} --out {args.out}")
        study_results.write(args.out, out)
        study_results.done(args.out)
    print(json.dumps(summarise(records), indent=1), flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
