"""Relative gains of pairs whose reference's self-noise follows the ground
motion (docs/validation/errors_in_variables.md, "Gains with a noisy
reference"): does each fitted relative gain hold the truth, or is it flagged
as not separable with the truth inside its reported bounds
(:mod:`bayescal.core.checks.gain_bounds`)?

Each pair: 1 h at 10 Hz, band 0.02-1 Hz, the SUT at a random azimuth with
horizontals 90 degrees apart, metadata gains off the truth by up to 3 %
(uniform), fitted by :func:`bayescal.calibrate` with the product's defaults
(gains free, ``--ref-noise estimate``) but the criticism off and the sampler
shortened (``min_ess`` 200, 20 autocorrelation times) for time. A regime is
the shape of each sensor's self-noise (``ground``: a fixed share of each
channel's own signal, the ground motion's spectrum; ``counts``: white in its
counts) and its level (squared coherence with the ground; for noise white in
counts at 0.2 Hz). A pair with the two sensors' noise of different shapes is
made from two simulations with one seed, which share the ground motion and
the noise draws (:func:`bayescal.simulate.simulate_pair` scales the same
draws): the SUT from one, the reference from the other.

Seeds, fixed before any result: regime ``r`` (index in :data:`REGIMES`),
pair ``k``: seed ``SEED0 + 1000 r + k``.

Per channel: ``hold`` (the truth inside the fit's 95 % interval), ``flagged``
(``separable`` false), ``in_bounds`` (the truth inside the bounds' outer
95 % interval), ``ok`` (held, or flagged with the truth in its bounds), and
whether the SUT-side gain's 95 % interval (+-1.96 sd) holds the truth.

    python validation/studies/refnoise_gain.py --n 30 \\
        --out validation/results/eiv/refnoise_gain.json

Resumable: pairs already in ``--out`` are skipped; ``--table`` reprints.
"""
from __future__ import annotations

import argparse
import json
import os
import time
import warnings

import numpy as np

import study_results                          # the sibling module, run as a script

SEED0 = 51000
NOMINAL = (30.0, 0.707, 750.0)
#: (name, SUT noise shape, SUT coherence, reference noise shape, reference coherence)
REGIMES = [
    ("ground/ground, ref 0.99", "ground", 0.99, "ground", 0.99),
    ("ground/ground, ref 0.95", "ground", 0.99, "ground", 0.95),
    ("ground/ground, ref 0.9", "ground", 0.99, "ground", 0.9),
    ("counts/ground, ref 0.99", "counts", 0.99, "ground", 0.99),
    ("counts/ground, ref 0.95", "counts", 0.99, "ground", 0.95),
    ("counts/ground, ref 0.9", "counts", 0.99, "ground", 0.9),
    ("counts/counts, ref 0.95", "counts", 0.99, "counts", 0.95),
    ("ground/ground, ref 0.9999", "ground", 0.99, "ground", 0.9999),
]


def simulate(seed, regime):
    """The pair of ``seed`` in ``regime``: (sut, sut_xml, ref, ref_xml, gains)."""
    from bayescal.simulate import simulate_pair
    _, s_shape, s_coh, r_shape, r_coh = regime
    rng = np.random.default_rng(seed)
    az = float(rng.uniform(0, 360))
    gains = tuple(float(g) for g in 1 + rng.uniform(-0.03, 0.03, 3))
    kw = dict(duration=3600.0, fs=10.0, seed=seed, coherence=s_coh, ref_coherence=r_coh,
              sut_azimuth=(az, az + 90.0, 0.0), nominal_azimuth=(az, az + 90.0, 0.0),
              nominal_response=NOMINAL,
              sut_response=tuple((NOMINAL[0], NOMINAL[1], NOMINAL[2] * g) for g in gains))
    a = simulate_pair(noise_in_counts=s_shape == "counts", **kw)
    b = a if s_shape == r_shape else simulate_pair(noise_in_counts=r_shape == "counts", **kw)
    return a.sut, a.sut_inventory, b.ref, b.ref_inventory, gains


def run_pair(seed, regime):
    """One seeded pair fitted: a row with each channel's checks."""
    import bayescal
    sut, sut_xml, ref, ref_xml, gains = simulate(seed, regime)
    t0 = time.process_time()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        res = bayescal.calibrate(ref=ref, ref_xml=ref_xml, sut=sut, sut_xml=sut_xml,
                                 band=(0.02, 1.0), progress=False, diagnose=False, seed=seed,
                                 min_ess=200, n_tau=20)
    summ = res.summary()
    bounds = summ["meta"]["reference_noise"]["gain_bounds"]["channels"]
    checks = {}
    for cid, truth in zip(summ["channels"], gains):
        rel = summ["channels"][cid]["response"]["relative_gain"]
        b = bounds[cid]
        lo, hi = b["interval95"]
        su = b["sut_side"]
        hold = bool(rel["ci95"][0] <= truth <= rel["ci95"][1])
        flagged = not b["separable"]
        in_b = bool(lo <= truth <= hi)
        checks[cid] = {"truth": truth, "median": rel["median"], "ci95": rel["ci95"],
                       "sd": rel["sd"], "correlation": sides_correlation(b),
                       "hold": hold, "flagged": flagged, "in_bounds": in_b,
                       "ok": bool(hold or (flagged and in_b)), "bounds": [b["lower"], b["upper"]],
                       "interval95": [lo, hi], "sut_gain": su["gain"], "sut_sd": su["sd"],
                       "ref_noise_fraction": su["reference_noise_fraction"],
                       "ref_side_gain": b["reference_side"]["gain"],
                       "difference_z": b["difference_z"],
                       "sut_hold": (None if su["gain"] is None or su["sd"] is None else
                                    bool(abs(su["gain"] - truth) <= 1.959964 * su["sd"]))}
    return {"seed": seed, "regime": regime[0], "cpu_s": time.process_time() - t0,
            "converged": bool(summ["convergence"].get("converged", True)), "checks": checks}


def sides_correlation(b):
    """The correlation of the SUT-side and the reference-side gains' errors
    of one channel's bounds entry ``b``, from their standard errors and
    that of their difference (``difference / difference_z``); None when
    any is missing."""
    su, sr, dz = b["sut_side"], b["reference_side"], b["difference_z"]
    if None in (su["gain"], su["sd"], sr["gain"], sr["sd"], dz) or dz == 0:
        return None
    d_sd = (su["gain"] - sr["gain"]) / dz
    return float((su["sd"] ** 2 + sr["sd"] ** 2 - d_sd ** 2) / (2 * su["sd"] * sr["sd"]))


def z_stats(values):
    """Mean and sd of standardised errors (None without any)."""
    v = np.asarray([x for x in values if x is not None], float)
    return {"mean": float(v.mean()), "sd": float(v.std(ddof=1)), "n": int(v.size)} \
        if v.size > 1 else None


def regime_z(cs):
    """The standardised errors of one regime's channels: the fit's relative
    gain, the SUT-side gain, the two sides' difference; and the two sides'
    error correlation (median and range)."""
    rho = [c["correlation"] for c in cs if c.get("correlation") is not None]
    return {"fit_z": z_stats((c["median"] - c["truth"]) / c["sd"] for c in cs),
            "sut_z": z_stats(None if c["sut_gain"] is None or not c["sut_sd"]
                             else (c["sut_gain"] - c["truth"]) / c["sut_sd"] for c in cs),
            "difference_z": z_stats(c["difference_z"] for c in cs),
            "correlation": ({"median": float(np.median(rho)),
                             "q10_q90": [float(q) for q in np.percentile(rho, [10, 90])]}
                            if rho else None)}


def outside_bounds(rows):
    """Every flagged channel whose truth lies outside the bounds' 95 %
    interval: its regime, channel and how far above (+) or below (-) the
    interval the truth is, in percent of the interval's end."""
    out = []
    for r in rows:
        for cid, c in r["checks"].items():
            if c["flagged"] and not c["in_bounds"]:
                lo, hi = c["interval95"]
                off = c["truth"] / hi - 1 if c["truth"] > hi else c["truth"] / lo - 1
                out.append({"regime": r["regime"], "seed": r["seed"], "channel": cid,
                            "percent_outside": 100 * off})
    return out


def summarise(rows):
    """Per regime: channels, held, flagged, flagged with the truth in the
    bounds, ok, and the SUT-side gain's coverage, with 99 % binomial bands
    at 95 %."""
    from bayescal.simulate.coverage import binomial_band
    out = []
    for name, *_ in REGIMES:
        cs = [c for r in rows if r["regime"] == name for c in r["checks"].values()]
        if not cs:
            continue
        n = len(cs)
        flagged = [c for c in cs if c["flagged"]]
        sut = [c["sut_hold"] for c in cs if c["sut_hold"] is not None]
        ok = sum(c["ok"] for c in cs)
        out.append({"regime": name, "pairs": sum(r["regime"] == name for r in rows), "n": n,
                    "hold": sum(c["hold"] for c in cs), "flagged": len(flagged),
                    "flagged_in_bounds": sum(c["in_bounds"] for c in flagged),
                    "unflagged_hold": sum(c["hold"] for c in cs if not c["flagged"]),
                    "unflagged": n - len(flagged), "ok": ok, "band95": list(binomial_band(n, 0.95)),
                    "pass": bool(ok >= binomial_band(n, 0.95)[0]),
                    "sut_hold": sum(sut), "sut_n": len(sut),
                    "sut_band95": list(binomial_band(len(sut), 0.95)) if sut else None,
                    "median_ref_noise_fraction": float(np.median(
                        [c["ref_noise_fraction"] for c in cs
                         if c["ref_noise_fraction"] is not None] or [np.nan])),
                    **(regime_z(cs) if all("sd" in c for c in cs) else {})})
    return out


def flagged_totals(rows):
    """Over every regime: channels flagged, flagged with the truth inside
    the bounds' 95 % interval, those outside (:func:`outside_bounds`), and
    the CPU minutes of the fits."""
    cs = [c for r in rows for c in r["checks"].values()]
    return {"flagged": sum(c["flagged"] for c in cs),
            "flagged_in_bounds": sum(c["flagged"] and c["in_bounds"] for c in cs),
            "outside": outside_bounds(rows),
            "cpu_minutes": sum(r["cpu_s"] for r in rows) / 60}


def table(summary):
    """Markdown table of :func:`summarise`."""
    lines = ["| SUT / reference noise, ref coherence | channels | held | flagged (truth in bounds) "
             "| unflagged held | ok [99 % band at 95 %] | SUT-side held [band] | x median |",
             "|---|---|---|---|---|---|---|---|"]
    for s in summary:
        lines.append(f"| {s['regime']} | {s['n']} | {s['hold']} | {s['flagged']} "
                     f"({s['flagged_in_bounds']}) | {s['unflagged_hold']} of {s['unflagged']} | "
                     f"{s['ok']} {s['band95']} | {s['sut_hold']} of {s['sut_n']} "
                     f"{s['sut_band95']} | {s['median_ref_noise_fraction']:.3f} |")
    return "\n".join(lines)


def criticism_gain_pairs(out):
    """The criticism study's gain-error pairs in noise shaped like the ground
    (validation/studies/criticism_harness.py, seed sets fourth to seventh,
    its first 60 effect seeds each), fitted as that study fits them (the
    criticism on): per channel, whether the relative gain's 95 % interval
    holds the truth, whether it is flagged, and whether the truth is inside
    its bounds. Written to ``out``."""
    import sys
    sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
    import bayescal
    import criticism_harness as ch
    from bayescal.simulate.pair import simulate_pair
    rows, t0 = [], time.process_time()
    for name in ("fourth", "fifth", "sixth", "seventh"):
        for seed in ch.SEED_SETS[name][1][:60]:
            kind = ch.KINDS[seed % len(ch.KINDS)]
            kw, truth, regime = ch.draw(seed, kind)
            if kind != "gain_error" or kw["noise_in_counts"]:
                continue
            sim = simulate_pair(**kw)
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                summ = bayescal.calibrate(sut=sim.sut, sut_xml=sim.sut_inventory, ref=sim.ref,
                                          ref_xml=sim.ref_inventory, band=ch.BAND,
                                          progress=False, seed=seed, min_ess=200,
                                          n_tau=20).summary()
            bounds = summ["meta"]["reference_noise"]["gain_bounds"]["channels"]
            for k, cid in enumerate(summ["channels"]):
                g = 1 + truth["fraction"] if k == truth["row"] else 1.0
                rel, b = summ["channels"][cid]["response"]["relative_gain"], bounds[cid]
                rows.append({"set": name, "seed": seed, "channel": cid, "truth": g,
                             "gain_error_channel": k == truth["row"],
                             "hold": bool(rel["ci95"][0] <= g <= rel["ci95"][1]),
                             "excludes_1": not rel["ci95"][0] <= 1.0 <= rel["ci95"][1],
                             "flagged": not b["separable"],
                             "in_bounds": bool(b["interval95"][0] <= g <= b["interval95"][1])})
            print(seed, flush=True)
    study_results.write(out, {"command": "python validation/studies/refnoise_gain.py "
                              "--criticism-pairs " + out, "rows": rows,
                              "summary": {"channels": len(rows),
                                          "held": sum(r["hold"] for r in rows),
                                          "flagged": sum(r["flagged"] for r in rows),
                                          "flagged_in_bounds": sum(r["flagged"] and r["in_bounds"]
                                                                   for r in rows),
                                          "by_set": gain_channels_by_set(rows),
                                          "cpu_minutes": (time.process_time() - t0) / 60}})


def gain_channels_by_set(rows):
    """Per seed set, the channels carrying the gain error: pairs, how many
    relative gains hold the truth, and the same among those the harness
    counts as measured (95 % interval excluding 1)."""
    out = {}
    for r in rows:
        if not r["gain_error_channel"]:
            continue
        d = out.setdefault(r["set"], {"pairs": 0, "held": 0, "measured": 0,
                                      "measured_held": 0})
        d["pairs"] += 1
        d["held"] += r["hold"]
        d["measured"] += r["excludes_1"]
        d["measured_held"] += r["excludes_1"] and r["hold"]
    return out


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--n", type=int, default=16, help="pairs per regime")
    ap.add_argument("--regimes", type=int, nargs="*", default=None, help="indices into REGIMES")
    ap.add_argument("--out", default="validation/results/eiv/refnoise_gain.json")
    ap.add_argument("--table", action="store_true", help="reprint the stored table only")
    ap.add_argument("--criticism-pairs", metavar="OUT", default=None,
                    help="rescore the criticism study's gain-error pairs into OUT instead")
    args = ap.parse_args(argv)
    if args.criticism_pairs:
        return criticism_gain_pairs(args.criticism_pairs)
    doc = {"rows": []}
    if os.path.exists(args.out):
        doc = study_results.read(args.out)
        doc.setdefault("rows", [])
    if not args.table:
        done = {r["seed"] for r in doc["rows"]}
        for k in range(args.n):      # interleaved so a stopped run covers every regime
            for r, regime in enumerate(REGIMES):
                seed = SEED0 + 1000 * r + k
                if (args.regimes is not None and r not in args.regimes) or seed in done:
                    continue
                doc["rows"].append(run_pair(seed, regime))
                doc["summary"] = summarise(doc["rows"])
                doc["flagged"] = flagged_totals(doc["rows"])
                doc["command"] = "python validation/studies/refnoise_gain.py --n %d" % args.n
                study_results.write(args.out, doc)
                print(seed, regime[0], round(doc["rows"][-1]["cpu_s"], 1), flush=True)
    print(table(summarise(doc["rows"])))


if __name__ == "__main__":
    main()
