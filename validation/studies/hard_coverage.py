"""Coverage and the prior-sensitivity flag in the hard regimes of a pair fit
with ``--fit-response all``.

Seeded simulated pairs, the truth of each SUT channel's period and damping
drawn from the stated prior (log-normal, 5 % around the metadata values),
its gain 2 % around nominal, its orientation and self-noise as in the
default coverage study (``bayescal.simulate.coverage.draw_case``). Regimes,
fixed by the seed before any result is seen:

* ``above``: a 120-, 240- or 360-s sensor seen from k = 5 to 20 times above
  its corner (band k f0 to 1 Hz), 10, 20 or 30 minutes at 5 Hz;
* ``corner``: a 120-s sensor with the band from 0.3 f0 to 0.4 Hz, one day at
  1 Hz (a huddle test's usual length: the lowest band then holds some 200
  periods);
* the reference's self-noise 0, 1 or 10 times the SUT's (in ground units);
* every fourth pair: the reference's metadata a few per cent off (its
  period, damping and gain each 2-5 % from the truth, random sign), fitted
  with that stated as the reference's tolerance (``reference_tolerance``
  3.6 %, the root mean square of such errors; the other pairs 0);
* both sensors' self-noise white in counts (``--noise ground``: shaped like
  the ground motion instead).

Each pair is fitted three times: with the default prior and with its
widths halved and doubled. The flag under test is the default fit's
(``meta.prior_sensitivity``, from the Gaussian approximation); the
reference is the same rule on the three fits' samples ("exact"): the
prior sets a value when its sd changes by more than 1.5 under the halved
or doubled prior, or its median moves by more than 0.5 sd under the
doubled one. Checked: every angle, every unflagged period, damping and
damping/period, and every gain (with the reference's metadata off,
against the stated tolerance) inside its 90 % interval at the binomial
rate; the flag raised where the exact rule says the
prior sets the value, and absent where the band reaches 0.3 f0. A record too
short for its band is refused by bayescal (an input error): such pairs are
listed, not fitted.

Coil runs (``--coil N``): a random (PRBS) calibration of a 120-s sensor
at 200 Hz, 20 or 60 minutes, fitted with ``bayescal cal --fit all`` (its
band starts far above the corner), the truth's period and damping drawn
from the stated prior, its gain 2 % around nominal, the same three fits and
the same checks; written to ``hard_coil.json``.

    python validation/studies/hard_coverage.py --n 80        # 240 fits less refusals
    python validation/studies/hard_coverage.py --coil 24 --out validation/results/coverage/hard_coil.json
    python validation/studies/hard_coverage.py --n 8 --out /tmp/hard.json
"""
from __future__ import annotations

import argparse
import json
import os
import time
import warnings

import numpy as np
import study_results                          # the sibling module, run as a script

from bayescal.core.response import pendulum
from bayescal.core.priors import Priors
from bayescal.pair.workflow import calibrate
from bayescal.errors import InputError
from bayescal.simulate.coverage import binomial_band, coverage_checks, draw_case
from bayescal.simulate.pair import simulate_pair, velocity_response

FS = 5.0
GAIN = 750.0
NAMES = ("period_s", "damping", "damping_over_period")


def draw_regime(seed):
    """The pair's regime and truth, from the seed alone."""
    rng = np.random.default_rng(20_000 + seed)
    regime = "corner" if seed % 5 == 4 else "above"
    t_nom = 120.0 if regime == "corner" else float(rng.choice([120.0, 240.0, 360.0]))
    f0 = 1.0 / t_nom
    if regime == "corner":
        k, duration, fs, top = 0.3, 86400.0, 1.0, 0.4
    else:
        fs, top = FS, 1.0
        k, duration = float(np.exp(rng.uniform(np.log(5), np.log(20)))), float(
            rng.choice([600.0, 1200.0, 1800.0]))
    truth = tuple((t_nom * np.exp(0.05 * rng.standard_normal()),
                   0.707 * np.exp(0.05 * rng.standard_normal()),
                   GAIN * (1 + 0.02 * rng.standard_normal())) for _ in range(3))
    ratio = (0.0, 1.0, 10.0)[seed % 3]
    ref_off = seed % 4 == 3
    off = tuple(rng.choice([-1, 1]) * rng.uniform(0.02, 0.05) for _ in range(3))
    return {"regime": regime, "nominal_period": t_nom, "k": k, "band": (k * f0, top),
            "duration": duration, "fs": fs, "truth": truth, "ref_noise_ratio": ratio,
            "ref_metadata_off": off if ref_off else None}


def simulate(seed, case, noise_in_counts=True):
    azs, dips, _, coh = draw_case(seed)
    noise = (1 - coh) / coh
    ref_coh = 1.0 / (1.0 + max(case["ref_noise_ratio"], 1e-6) * noise)
    sim = simulate_pair(duration=case["duration"], fs=case["fs"], seed=seed, coherence=coh,
                        ref_coherence=ref_coh, sut_azimuth=azs, sut_dip=dips,
                        sut_response=case["truth"],
                        nominal_response=(case["nominal_period"], 0.707, GAIN),
                        noise_in_counts=noise_in_counts)
    if case["ref_metadata_off"]:
        a, b, c = case["ref_metadata_off"]
        for ch in sim.ref_inventory[0][0]:
            ch.response = velocity_response(120.0 * (1 + a), 0.707 * (1 + b), 1500.0 * (1 + c),
                                            sample_rate=case["fs"])
    return sim, azs, dips, coh


#: The reference's tolerance stated for the pairs whose metadata are off.
REF_TOLERANCE = 0.036


def fit(sim, band, scale, seed, ref_tolerance=0.0):
    pr = Priors(period_tolerance=pendulum.PERIOD_TOLERANCE * scale,
                damping_tolerance=pendulum.DAMPING_TOLERANCE * scale,
                reference_tolerance=ref_tolerance)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return calibrate(ref=sim.ref, ref_xml=sim.ref_inventory, sut=sim.sut,
                         sut_xml=sim.sut_inventory, band=band, fit_response="all", seed=seed,
                         priors=pr, progress=False)


def _logs(post, cid):
    r = post.response[cid]
    return {"period_s": np.log(r[:, 0]), "damping": np.log(r[:, 1]),
            "damping_over_period": np.log(r[:, 1] / r[:, 0])}


def exact_flags(posts, cid):
    """The prior-sensitivity rule on the samples of the fits with the
    prior's width x1, x0.5 and x2."""
    return rule_on_samples(*(_logs(p, cid) for p in posts))


def _half_range(x):
    """Half the spread between the 16th and 84th percentiles (an sd that a
    few far samples do not move)."""
    lo, hi = np.quantile(x, (0.16, 0.84))
    return float((hi - lo) / 2)


def rule_on_samples(base, half, double):
    """The prior-sensitivity rule on three fits' log period, damping and
    damping/period samples (prior width x1, x0.5, x2), with the spread the
    flag uses (:func:`_half_range`, as ``bayescal.core.response.pendulum``
    does): a few far samples (a period the reference's tolerance sends
    beyond 1e6 s) do not move it. ``width_ratio_sd``: the ratio by the
    standard deviation, for the record."""
    out = {}
    for name in NAMES:
        hr1 = _half_range(base[name])
        width = max(max(_half_range(x[name]) / hr1, hr1 / _half_range(x[name]))
                    for x in (half, double))
        sd1 = base[name].std()
        width_sd = max(max(x[name].std() / sd1, sd1 / x[name].std()) for x in (half, double))
        shift = abs(np.median(double[name]) - np.median(base[name])) / hr1
        out[name] = {"set_by_prior": bool(width > pendulum.WIDTH_RATIO
                                          or shift > pendulum.SHIFT_SD),
                     "width_ratio": float(width), "shift_sd": float(shift),
                     "width_ratio_sd": float(width_sd)}
    return out


def run_case(seed, noise_in_counts=True):
    case = draw_regime(seed)
    sim, azs, dips, coh = simulate(seed, case, noise_in_counts)
    try:
        tol = REF_TOLERANCE if case["ref_metadata_off"] else 0.0
        posts = [fit(sim, case["band"], s, seed, tol) for s in (1.0, 0.5, 2.0)]
    except InputError as exc:       # a record too short for its band: bayescal refuses it
        return {"seed": seed, **{k: v for k, v in case.items() if k != "truth"},
                "refused": str(exc)}
    post = posts[0]
    summary = post.summary()
    angle = {k: v for k, v in coverage_checks(post, azs, dips, case["truth"]).items()
             if k.split(":")[1] in ("azimuth", "dip", "tilt_north", "tilt_east")}
    channels = {}
    for k, cid in enumerate(post.channel_ids):
        t, h, g = case["truth"][k]
        truth = {"period_s": t, "damping": h, "damping_over_period": h / t, "gain": g}
        resp = summary["channels"][cid]["response"]
        r = post.response[cid]
        samples = {"period_s": r[:, 0], "damping": r[:, 1], "damping_over_period": r[:, 1] / r[:, 0],
                   "gain": r[:, 2]}
        entry = {}
        for name, s in samples.items():
            lo, hi = np.percentile(s, [5, 95])
            entry[name] = {"inside90": bool(lo <= truth[name] <= hi),
                           "z": float((np.median(s) - truth[name]) / s.std()),
                           "flag": bool(resp[name].get("set_by_prior", False))}
        for name, e in exact_flags(posts, cid).items():
            entry[name]["exact"] = e
        channels[cid] = entry
    conv = [p.summary()["convergence"] for p in posts]
    return {"seed": seed, **{k: v for k, v in case.items() if k != "truth"},
            "truth": case["truth"], "coherence": coh, "angles": angle, "channels": channels,
            "converged": all(c["converged"] for c in conv),
            "steps": [c["n_steps"] for c in conv]}


COIL_CONSTANT = 1e-9


def run_coil_case(i):
    """A random coil run with ``--fit all`` (module docstring), three fits."""
    from bayescal import coil
    from bayescal.coil.random import fit_random
    from bayescal.simulate.cal import HF_NOMINAL, simulate_random_cal
    rng = np.random.default_rng(40_000 + i)
    nominal = (120.0, 0.707, 1500.0)
    truth = (nominal[0] * np.exp(0.05 * rng.standard_normal()),
             nominal[1] * np.exp(0.05 * rng.standard_normal()),
             nominal[2] * (1 + 0.02 * rng.standard_normal()))
    duration = float(rng.choice([1200.0, 3600.0]))
    sim = simulate_random_cal(truth=truth, nominal=nominal, hf_true=HF_NOMINAL,
                              hf_nominal=HF_NOMINAL, duration=duration, fs=200.0, seed=41_000 + i)
    run = coil.read_run("U", sim.runs["cal"], sim.inventory, "BC0", "sim")
    fits = []
    for scale in (1.0, 0.5, 2.0):
        pr = Priors(period_tolerance=pendulum.PERIOD_TOLERANCE * scale,
                    damping_tolerance=pendulum.DAMPING_TOLERANCE * scale)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            fits.append(fit_random(run, COIL_CONSTANT, fit="all", seed=i, priors=pr))
    logs = []
    for f in fits:
        ph = f.physical()
        logs.append({"period_s": np.log(ph["period_s"]), "damping": np.log(ph["damping"]),
                     "damping_over_period": np.log(ph["damping"] / ph["period_s"])})
    params = fits[0].summary()["parameters"]
    want = {"period_s": truth[0], "damping": truth[1], "gain": truth[2],
            "damping_over_period": truth[1] / truth[0]}
    entry = {}
    for name, t in want.items():
        e = params[name]
        entry[name] = {"inside90": bool(e["ci90"][0] <= t <= e["ci90"][1]),
                       "z": float((e["median"] - t) / e["sd"]),
                       "flag": bool(e.get("set_by_prior", False))}
    for name, e in rule_on_samples(*logs).items():
        entry[name]["exact"] = e
    return {"seed": i, "duration": duration, "truth": truth, "band_hz": list(fits[0].band_hz),
            "channel": entry,
            "converged": all(f.summary()["convergence"]["converged"] for f in fits)}


def summarise_coil(rows):
    cov = {name + (" (unflagged)" if name in NAMES else ""): [
        r["channel"][name]["inside90"] for r in rows
        if name not in NAMES or not r["channel"][name]["flag"]]
        for name in ("period_s", "damping", "damping_over_period", "gain")}
    flags = {}
    for name in NAMES:
        items = [(r["channel"][name]["flag"], r["channel"][name]["exact"]["set_by_prior"])
                 for r in rows]
        prior_set = [f for f, x in items if x]
        flags[name] = {"exact_says_prior_sets": len(prior_set),
                       "flag_raised_there": int(sum(prior_set)),
                       "flag_absent_where_exact_says_data": int(sum(not f for f, x in items
                                                                    if not x)),
                       "exact_says_data": int(sum(not x for _, x in items)),
                       "agreement": float(np.mean([f == x for f, x in items]))}
    return {"coverage90": {k: _count(v) for k, v in cov.items()}, "flags": flags,
            "runs": len(rows), "fits": 3 * len(rows),
            "converged": int(sum(r["converged"] for r in rows))}


def _count(pairs):
    n = len(pairs)
    k = int(sum(pairs))
    lo, hi = binomial_band(n) if n else (0, 0)
    return {"n": n, "inside": k, "rate": k / n if n else None, "band99": [lo, hi],
            "consistent": bool(lo <= k <= hi) if n else None}


def corner_data_fix(rows):
    """At the corner, the values the refits say the data fix (period,
    damping, damping/period of every channel, pooled): how many, how many
    the flag leaves unflagged, and each one flagged (seed, channel, name,
    the median's shift under the doubled prior in sds, the reference's
    noise ratio)."""
    items = [(r, cid, name, e[name]) for r in rows if r["regime"] == "corner"
             for cid, e in r["channels"].items() for name in NAMES
             if not e[name]["exact"]["set_by_prior"]]
    return {"values": len(items), "flag_absent": sum(not x["flag"] for *_, x in items),
            "flagged": [{"seed": r["seed"], "channel": cid, "name": name,
                         "shift_sd": x["exact"]["shift_sd"], "ref_noise_ratio": r["ref_noise_ratio"]}
                        for r, cid, name, x in items if x["flag"]]}


#: A refit's sd this many times the default fit's cannot come from halving
#: or doubling the prior (which changes a Gaussian posterior's sd by at most
#: a factor 2): the refit, not the prior, moved.
REFIT_BLOWN = 3.0


def _sd_ratio(x):
    """A refit's width ratio by the standard deviation (stored as
    ``width_ratio_sd``; runs written before it was stored hold it as
    ``width_ratio``)."""
    return x["exact"].get("width_ratio_sd", x["exact"]["width_ratio"])


def flag_misses(rows):
    """The values the refits say the prior sets but the flag leaves
    unflagged: how many, how many in pairs whose reference's tolerance is
    stated, how many whose refit's sd is :data:`REFIT_BLOWN` or more times
    the default fit's (with the range of those ratios), and each of the
    others (seed, channel, name, width ratio, shift, tolerance stated)."""
    items = [(r, cid, name, e[name]) for r in rows for cid, e in r["channels"].items()
             for name in NAMES if e[name]["exact"]["set_by_prior"] and not e[name]["flag"]]
    blown = [(r, x) for r, *_, x in items if _sd_ratio(x) >= REFIT_BLOWN]
    ratios = [_sd_ratio(x) for _, x in blown]
    return {"misses": len(items),
            "with_tolerance": sum(bool(r["ref_metadata_off"]) for r, *_ in items),
            "refit_blown": len(blown),
            "refit_blown_tolerance": sum(bool(r["ref_metadata_off"]) for r, _ in blown),
            "refit_blown_ratio": [min(ratios), max(ratios)] if ratios else None,
            "refit_blown_pairs": sorted({r["seed"] for r, _ in blown}),
            "others": [{"seed": r["seed"], "channel": cid, "name": name,
                        "width_ratio": x["exact"]["width_ratio"],
                        "shift_sd": x["exact"]["shift_sd"],
                        "tolerance": bool(r["ref_metadata_off"])}
                       for r, cid, name, x in items if _sd_ratio(x) < REFIT_BLOWN]}


def refit_spread(seed, noise_in_counts=True):
    """One pair's three fits looked at closely: per channel and value the
    log samples' sd and half 16-84 % range in each fit (prior width x1,
    x0.5, x2), the samples whose period exceeds 1e6 s, the width ratio and
    shift by either spread, and each fit's convergence."""
    case = draw_regime(seed)
    sim, *_ = simulate(seed, case, noise_in_counts)
    tol = REF_TOLERANCE if case["ref_metadata_off"] else 0.0
    posts = [fit(sim, case["band"], s, seed, tol) for s in (1.0, 0.5, 2.0)]
    out = {"seed": seed, "nominal_period": case["nominal_period"], "tolerance": tol,
           "samples": int(posts[0].response[posts[0].channel_ids[0]].shape[0]),
           "convergence": [{k: p.summary()["convergence"][k]
                            for k in ("converged", "n_steps", "rhat_max", "ess_min")}
                           for p in posts], "channels": {}}
    for cid in posts[0].channel_ids:
        logs = [_logs(p, cid) for p in posts]
        entry = {"far_periods": [int((p.response[cid][:, 0] > 1e6).sum()) for p in posts],
                 "largest_period": [float(p.response[cid][:, 0].max()) for p in posts]}
        for name in NAMES:
            sd = [float(x[name].std()) for x in logs]
            hr = [_half_range(x[name]) for x in logs]
            shift = abs(np.median(logs[2][name]) - np.median(logs[0][name]))
            entry[name] = {"sd": sd, "half_range": hr,
                           "width_ratio_sd": max(max(v / sd[0], sd[0] / v) for v in sd[1:]),
                           "width_ratio_half_range": max(max(v / hr[0], hr[0] / v)
                                                         for v in hr[1:]),
                           "shift_sd": float(shift / sd[0]),
                           "shift_half_range": float(shift / hr[0])}
        out["channels"][cid] = entry
    return out


def summarise(all_rows):
    rows = [r for r in all_rows if "refused" not in r]
    cov = {"angles": [v[0] for r in rows for v in r["angles"].values()]}
    for name in NAMES:
        cov[name + " (unflagged)"] = [e[name]["inside90"] for r in rows
                                      for e in r["channels"].values() if not e[name]["flag"]]
    cov["gain (reference metadata right)"] = [e["gain"]["inside90"] for r in rows
                                              if not r["ref_metadata_off"]
                                              for e in r["channels"].values()]
    cov["gain (reference metadata off)"] = [e["gain"]["inside90"] for r in rows
                                            if r["ref_metadata_off"]
                                            for e in r["channels"].values()]
    table = {"coverage90": {k: _count(v) for k, v in cov.items()}}
    flags = {}
    for name in NAMES:
        items = [(e[name]["flag"], e[name]["exact"]["set_by_prior"], r["regime"])
                 for r in rows for e in r["channels"].values()]
        prior_set = [f for f, x, _ in items if x]
        corner = [f for f, _, reg in items if reg == "corner"]
        flags[name] = {
            "exact_says_prior_sets": len(prior_set),
            "flag_raised_there": int(sum(prior_set)),
            "rate_raised": float(np.mean(prior_set)) if prior_set else None,
            "band_reaches_0.3f0": len(corner),
            "flag_absent_there": int(len(corner) - sum(corner)),
            "rate_absent": float(1 - np.mean(corner)) if corner else None,
            "agreement": float(np.mean([f == x for f, x, _ in items]))}
    table["flags"] = flags
    table["flag_misses"] = flag_misses(rows)
    table["corner_data_fix"] = corner_data_fix(rows)
    table["gain_by_ref_noise_ratio"] = {
        format(ratio, "g"): _count([e["gain"]["inside90"] for r in rows
                                    if not r["ref_metadata_off"] and r["ref_noise_ratio"] == ratio
                                    for e in r["channels"].values()])
        for ratio in sorted({r["ref_noise_ratio"] for r in rows})}
    by = {}
    for key in ("regime", "ref_noise_ratio"):
        for val in sorted({r[key] for r in rows}, key=str):
            sub = [r for r in rows if r[key] == val]
            by[f"{key}={val}"] = {
                "pairs": len(sub),
                "angles": _count([v[0] for r in sub for v in r["angles"].values()]),
                "damping_over_period (unflagged)": _count(
                    [e["damping_over_period"]["inside90"] for r in sub
                     for e in r["channels"].values() if not e["damping_over_period"]["flag"]])}
    sub = [r for r in rows if r["ref_metadata_off"]]
    by["reference metadata off"] = {
        "pairs": len(sub),
        "damping_over_period (unflagged)": _count(
            [e["damping_over_period"]["inside90"] for r in sub for e in r["channels"].values()
             if not e["damping_over_period"]["flag"]])}
    table["by_regime"] = by
    table["converged"] = int(sum(r["converged"] for r in rows))
    table["pairs_fitted"] = len(rows)
    table["fits"] = 3 * len(rows)
    table["refused"] = {str(r["seed"]): r["refused"] for r in all_rows if "refused" in r}
    return table


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--n", type=int, default=80, help="pairs (three fits each)")
    ap.add_argument("--first", type=int, default=0)
    ap.add_argument("--noise", choices=("counts", "ground"), default="counts",
                    help="both sensors' self-noise white in counts (as real self-noise is; "
                         "the default) or shaped like the ground motion (which a pair cannot "
                         "tell from a gain: the reference's noise is then not identified)")
    ap.add_argument("--coil", type=int, default=0, metavar="N",
                    help="N coil runs with --fit all instead of the pairs")
    ap.add_argument("--out", default="validation/results/coverage/hard.json")
    ap.add_argument("--summarise", action="store_true",
                    help="rewrite --out's summary from the per-run records beside it, "
                         "without fitting")
    ap.add_argument("--refit-spread", type=int, nargs="+", metavar="SEED",
                    help="look closely at these pairs' three fits (refit_spread) and write "
                         "them to --out instead")
    args = ap.parse_args(argv)
    if args.refit_spread:
        rows = [refit_spread(seed, args.noise == "counts") for seed in args.refit_spread]
        study_results.write(args.out, {"pairs": rows, "config": vars(args)})
        print(json.dumps(rows[0]["channels"], indent=1)[:2000])
        return
    if args.summarise:
        doc = study_results.read(args.out)
        doc["table"] = summarise(doc["runs"])
        study_results.write(args.out, doc)
        print(json.dumps(doc["table"]["flag_misses"], indent=1))
        return
    os.makedirs(os.path.dirname(os.path.abspath(args.out)), exist_ok=True)
    rows, t0 = [], time.time()
    if args.coil:
        for i in range(args.first, args.first + args.coil):
            rows.append(run_coil_case(i))
            print(f"[{len(rows)}/{args.coil}] coil run {i} {rows[-1]['duration']:g} s "
                  f"({time.time() - t0:.0f} s)", flush=True)
        table = summarise_coil(rows)
        study_results.write(args.out, {"table": table, "config": vars(args),
                                       "seconds": time.time() - t0, "runs": rows})
        print(json.dumps(table, indent=1))
        return
    for seed in range(args.first, args.first + args.n):
        rows.append(run_case(seed, args.noise == "counts"))
        r = rows[-1]
        print(f"[{len(rows)}/{args.n}] seed {seed} {r['regime']} k={r['k']:.1f} "
              f"{'REFUSED ' if 'refused' in r else ''}"
              f"T0={r['nominal_period']:g} {r['duration']:g} s ratio {r['ref_noise_ratio']:g} "
              f"ref off {bool(r['ref_metadata_off'])} ({time.time() - t0:.0f} s)", flush=True)
        if len(rows) % 5 == 0 and len(rows) < args.n:       # the pairs so far, kept
            study_results.write(args.out, {"table": summarise(rows), "config": vars(args),
                                           "seconds": time.time() - t0, "partial": True,
                                           "runs": rows})
    table = summarise(rows)
    study_results.write(args.out, {"table": table, "config": vars(args),
                                   "seconds": time.time() - t0, "runs": rows})
    print(json.dumps(table, indent=1))


if __name__ == "__main__":
    main()
