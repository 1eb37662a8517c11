"""Coverage of the SUT's response when the reference's metadata are off by
a draw from their stated tolerance (``--ref-tolerance``).

Seeded simulated pairs, everything fixed by the seed before any result is
seen: the SUT's nominal period 120, 240 or 360 s (the reference 120 s,
damping 0.707), the band from k = 5 to 20 times the SUT's corner up to
1 Hz, 20 or 30 minutes at 5 Hz; each SUT channel's true period and damping
drawn from its stated prior (log-normal, 5 % around the metadata), its gain
2 % around nominal, orientation and coherence as in the default coverage
study, the reference as noisy as the SUT. Each reference channel's
metadata are off by its own draw from the stated tolerance (gain, period
and damping each ``exp(e)``, ``e ~ N(0, tol^2)``); the pair is fitted with
``--fit-response all`` and that tolerance. Checked: each SUT channel's
gain, period, damping and damping/period inside its 90 % interval at the
binomial rate. Beside it, the same fits' samples moved by the reference's
error without the SUT's prior weighing them (the moves alone), and the
Kish share of the weighted draws.

    python validation/studies/reference_tolerance_coverage.py --n 40 --out validation/results/coverage/reference_tolerance.json
"""
from __future__ import annotations

import argparse
import json
import time
import warnings
from types import SimpleNamespace

import numpy as np
import study_results                          # the sibling module, run as a script

from bayescal.core.priors import Priors
from bayescal.core.response import widen_responses
from bayescal.errors import InputError
from bayescal.pair.workflow import calibrate
from bayescal.simulate.coverage import binomial_band, draw_case
from bayescal.simulate.pair import simulate_pair, velocity_response

GAIN, FS = 750.0, 5.0
NAMES = ("gain", "period_s", "damping", "damping_over_period")


def draw(seed, tol):
    """The pair's setting and truth, from the seed alone."""
    rng = np.random.default_rng(30_000 + seed)
    t_nom = float(rng.choice([120.0, 240.0, 360.0]))
    k = float(np.exp(rng.uniform(np.log(5), np.log(20))))
    duration = float(rng.choice([1200.0, 1800.0]))
    truth = tuple((t_nom * np.exp(0.05 * rng.standard_normal()),
                   0.707 * np.exp(0.05 * rng.standard_normal()),
                   GAIN * (1 + 0.02 * rng.standard_normal())) for _ in range(3))
    ref_off = np.exp(tol * rng.standard_normal((3, 3)))      # per reference channel: T, h, G
    return {"nominal_period": t_nom, "k": k, "band": (k / t_nom, 1.0), "duration": duration,
            "truth": truth, "ref_off": ref_off.tolist()}


def _inside(samples, truth):
    lo, hi = np.percentile(samples, [5, 95])
    return bool(lo <= truth <= hi)


def _values(r):
    return {"gain": r[:, 2], "period_s": r[:, 0], "damping": r[:, 1],
            "damping_over_period": r[:, 1] / r[:, 0]}


def run_case(seed, tol):
    case = draw(seed, tol)
    azs, dips, _, coh = draw_case(seed)
    sim = simulate_pair(duration=case["duration"], fs=FS, seed=seed, coherence=coh,
                        ref_coherence=coh, sut_azimuth=azs, sut_dip=dips,
                        sut_response=case["truth"],
                        nominal_response=(case["nominal_period"], 0.707, GAIN),
                        noise_in_counts=True)
    for ch, (a, b, c) in zip(sim.ref_inventory[0][0], case["ref_off"]):
        ch.response = velocity_response(120.0 * a, 0.707 * b, 1500.0 * c, sample_rate=FS)
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            post = calibrate(ref=sim.ref, ref_xml=sim.ref_inventory, sut=sim.sut,
                             sut_xml=sim.sut_inventory, band=case["band"], fit_response="all",
                             seed=seed, progress=False, diagnose=False,
                             priors=Priors(reference_tolerance=tol))
    except InputError as exc:            # a record too short for its band: refused
        return {"seed": seed, **case, "refused": str(exc)}
    state = post.state
    # the moves alone: the fit's samples moved without the SUT's prior weighing them
    # (the reference's channels north, east, vertical: their metadata as the fit took them)
    fams = [SimpleNamespace(period_s=120.0 * a, damping=0.707 * b) for a, b, _ in case["ref_off"]]
    moves, _ = widen_responses(state.response, state.channel_ids,
                               sut_vectors=post.vectors.mean(axis=0), ref_vectors=np.eye(3),
                               ref_families=fams, tolerance=tol, seed=seed)
    summary = post.summary()
    rt = post.meta.reference_tolerance
    channels = {}
    for k, cid in enumerate(post.channel_ids):
        t, h, g = case["truth"][k]
        truth = {"gain": g, "period_s": t, "damping": h, "damping_over_period": h / t}
        resp = summary["channels"][cid]["response"]
        got, old = _values(post.response[cid]), _values(moves[cid])
        channels[cid] = {name: {"inside90": _inside(got[name], truth[name]),
                                "moves_alone_inside90": _inside(old[name], truth[name]),
                                "flag": bool(resp[name].get("set_by_prior", False))}
                         for name in NAMES}
        channels[cid]["kish_fraction"] = rt["kish_fraction"][cid]
        channels[cid]["effective_draws"] = rt["effective_draws"][cid]
    return {"seed": seed, **case, "channels": channels,
            "converged": bool(summary["convergence"]["converged"])}


def summarise(rows):
    """Per quantity: truths inside the 90 % intervals (weighted and by the
    moves alone) with the 99 % binomial band; the Kish shares."""
    fitted = [r for r in rows if "channels" in r]
    chans = [c for r in fitted for c in r["channels"].values()]
    n = len(chans)
    lo, hi = binomial_band(n, 0.9, 0.01) if n else (0, 0)
    table = {name: {"inside": sum(c[name]["inside90"] for c in chans),
                    "moves_alone_inside": sum(c[name]["moves_alone_inside90"] for c in chans),
                    "flagged": sum(c[name]["flag"] for c in chans), "n": n, "band": [lo, hi]}
             for name in NAMES}
    kish = np.array([c["kish_fraction"] for c in chans]) if chans else np.zeros(0)
    by_period, by_draws = {}, {}
    for r in fitted:
        for c in r["channels"].values():
            by_period.setdefault(str(int(r["nominal_period"])), []).append(c)
            edge = next(e for e in DRAW_BINS[1:] + [np.inf] if c["effective_draws"] < e)
            by_draws.setdefault(str(edge), []).append(c)
    return {"quantities": table, "pairs": len(fitted), "refused": len(rows) - len(fitted),
            "converged": sum(r["converged"] for r in fitted),
            "by_period": {k: _group(v)
                          for k, v in sorted(by_period.items(), key=lambda x: float(x[0]))},
            "by_effective_draws_below": {k: _group(v) for k, v in
                                         sorted(by_draws.items(), key=lambda x: float(x[0]))},
            "kish_below_0.1": int((kish < 0.1).sum())}


#: Bins of the effective draws (lower edges) for the coverage by draws.
DRAW_BINS = [0, 100, 300, 1000]


def _group(chans):
    """Coverage counts, band and the Kish share's median of a group of channels."""
    n = len(chans)
    return {"n": n, "band": list(binomial_band(n, 0.9, 0.01)),
            "inside": {name: sum(c[name]["inside90"] for c in chans) for name in NAMES},
            "kish_median": float(np.median([c["kish_fraction"] for c in chans])),
            "effective_draws_median": float(np.median([c["effective_draws"] for c in chans]))}


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--n", type=int, default=40, help="pairs")
    ap.add_argument("--first", type=int, default=0)
    ap.add_argument("--tolerance", type=float, default=0.036,
                    help="the reference's tolerance (relative sd; default 0.036)")
    ap.add_argument("--out", default="validation/results/coverage/reference_tolerance.json")
    args = ap.parse_args(argv)
    done, before = {}, 0.0            # the runs stored by an earlier call, and their seconds
    try:
        doc = study_results.read(args.out)
        done, before = {r["seed"]: r for r in doc.get("runs", [])}, doc.get("seconds", 0.0)
    except (OSError, ValueError):
        pass
    rows, t0 = [], time.time()
    for seed in range(args.first, args.first + args.n):
        rows.append(done.get(seed) or run_case(seed, args.tolerance))
        r = rows[-1]
        print(f"[{len(rows)}/{args.n}] seed {seed} T0={r['nominal_period']:g} k={r['k']:.1f} "
              f"{'REFUSED' if 'refused' in r else ''} ({time.time() - t0:.0f} s)", flush=True)
        if len(rows) % 5 == 0 or len(rows) == args.n:       # kept as they come
            doc = {"table": summarise(rows), "config": vars(args), "runs": rows,
                   "partial": len(rows) < args.n, "seconds": before + time.time() - t0}
            study_results.write(args.out, doc)
    print(json.dumps(doc["table"], indent=1))


if __name__ == "__main__":
    main()
