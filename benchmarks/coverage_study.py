"""Coverage of bayescal's credible intervals over seeded simulated pairs.

For each seed: a random SUT orientation (any azimuth, small dips, a tilted
vertical), random true responses (period, damping, gain off nominal by a few
per cent), a coherence drawn log-uniformly in 1 - coherence from [0.001, 0.1]
(coherence 0.9 to 0.999); the joint posterior (angles and response: 15
parameters) is sampled with the default convergence rule and each truth is
checked against its 90 % interval. Writes a table (JSON) and a plot into
reports/coverage/.

    python benchmarks/coverage_study.py --n 100            # the full study
    python benchmarks/coverage_study.py --n 20 --out /tmp/cov

Truth for a channel's axis is checked as azimuth and dip for horizontals and
as tilt from vertical for the near-vertical channel.
"""
from __future__ import annotations

import argparse
import json
import os
import time

import numpy as np
from scipy.stats import binom

import bayescal
from bayescal.geometry import tilt_from_vertical, unit_vector, unwrap_azimuths
from bayescal.simulate import simulate_pair

NOMINAL = (30.0, 0.707, 750.0)


def draw_case(seed):
    """Random truth for one simulated pair."""
    rng = np.random.default_rng(10_000 + seed)
    az = rng.uniform(0, 360)
    azs = (az, az + 90 + rng.normal(0, 1), rng.uniform(0, 360))
    dips = (rng.normal(0, 1), rng.normal(0, 1), -90 + abs(rng.normal(0, 1)))
    resp = tuple(tuple(np.array(NOMINAL) * (1 + rng.normal(0, [0.05, 0.05, 0.02])))
                 for _ in range(3))
    coherence = 1 - 10 ** rng.uniform(-3, -1)
    return azs, dips, resp, coherence


def run_case(seed, duration, fs, band, fit_response):
    azs, dips, resp, coh = draw_case(seed)
    if fit_response == "none":
        resp = (NOMINAL,) * 3
    sim = simulate_pair(duration=duration, fs=fs, seed=seed, coherence=coh, sut_azimuth=azs,
                        sut_dip=dips, sut_response=resp, nominal_response=NOMINAL)
    post = bayescal.calibrate(sim.sut, sim.sut_inventory, sim.ref, sim.ref_inventory, band=band,
                              fit_response=fit_response, seed=seed, progress=False)
    return post, azs, dips, resp, coh


def coverage_checks(post, azs, dips, resp, level=90.0):
    """Dict name -> (inside interval?, standardised error) for every truth."""
    lo_q, hi_q = (100 - level) / 2, 100 - (100 - level) / 2
    out = {}
    az, dip = post.azimuth_dip
    for k, cid in enumerate(post.channel_ids):
        short = cid.split(".")[-1]
        if abs(dips[k]) > 80:
            tilt = tilt_from_vertical(post.vectors[:, k])[0]
            truth = float(tilt_from_vertical(unit_vector(azs[k], dips[k]))[0])
            pairs = {f"{short}:tilt": (tilt, truth)}
        else:
            a = unwrap_azimuths(np.r_[az[:, k], azs[k]])
            pairs = {f"{short}:azimuth": (a[:-1], a[-1]), f"{short}:dip": (dip[:, k], dips[k])}
        if cid in post.response:
            r = post.response[cid]
            names = ("period", "damping", "gain") if post.meta["free_response"] == "all" else ()
            if post.meta["free_response"] == "gain":
                names = ("gain",)
            for name in names:
                j = ("period", "damping", "gain").index(name)
                pairs[f"{short}:{name}"] = (r[:, j], resp[k][j])
        for name, (s, truth) in pairs.items():
            lo, hi = np.percentile(s, [lo_q, hi_q])
            out[name] = (bool(lo <= truth <= hi), float((np.median(s) - truth) / np.std(s)))
    return out


def binomial_band(n, p=0.9, alpha=0.01):
    """Central (1 - alpha) band for the count of successes."""
    return int(binom.ppf(alpha / 2, n, p)), int(binom.ppf(1 - alpha / 2, n, p))


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--n", type=int, default=100)
    ap.add_argument("--duration", type=float, default=3600.0)
    ap.add_argument("--fs", type=float, default=10.0)
    ap.add_argument("--band", type=float, nargs=2, default=(0.01, 1.0))
    ap.add_argument("--fit-response", default="all", choices=("none", "gain", "all"))
    ap.add_argument("--out", default="reports/coverage")
    args = ap.parse_args(argv)
    os.makedirs(args.out, exist_ok=True)
    rows, t0 = [], time.time()
    for seed in range(args.n):
        post, azs, dips, resp, coh = run_case(seed, args.duration, args.fs, tuple(args.band),
                                              args.fit_response)
        checks = coverage_checks(post, azs, dips, resp)
        conv = post.summary()["convergence"]
        rows.append({"seed": seed, "coherence": coh, "checks": checks,
                     "ess_min": conv["ess_min"], "rhat_max": conv["rhat_max"],
                     "converged": conv["converged"]})
        inside = np.mean([v[0] for r in rows for v in r["checks"].values()])
        print(f"[{seed + 1}/{args.n}] coherence {coh:.4f}  running coverage {inside:.3f}  "
              f"({time.time() - t0:.0f} s)", flush=True)
    table = summarise(rows)
    plot(rows, table, os.path.join(args.out, "coverage.png"))
    with open(os.path.join(args.out, "coverage.json"), "w") as fh:
        json.dump({"table": table, "config": vars(args), "seconds": time.time() - t0,
                   "runs": rows}, fh, indent=1)
    print(json.dumps(table, indent=1))


def summarise(rows):
    """Per parameter kind and overall: count inside, band, verdict."""
    kinds = {}
    for r in rows:
        for name, (inside, z) in r["checks"].items():
            kind = name.split(":")[1]
            kinds.setdefault(kind, []).append((inside, z))
    out = {}
    allv = [v for vals in kinds.values() for v in vals]
    for kind, vals in list(kinds.items()) + [("all", allv)]:
        n = len(vals)
        k = int(sum(v[0] for v in vals))
        lo, hi = binomial_band(n)
        z = np.array([v[1] for v in vals])
        out[kind] = {"n": n, "inside": k, "rate": k / n, "band99": [lo, hi],
                     "consistent": bool(lo <= k <= hi), "z_mean": float(z.mean()),
                     "z_sd": float(z.std())}
    return out


def plot(rows, table, path):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig, axes = plt.subplots(1, 2, figsize=(10, 4), constrained_layout=True)
    kinds = [k for k in table if k != "all"]
    rates = [table[k]["rate"] for k in kinds]
    bands = np.array([table[k]["band99"] for k in kinds]) / np.array([table[k]["n"] for k in kinds])[:, None]
    x = np.arange(len(kinds))
    axes[0].errorbar(x, rates, fmt="ko", label="observed rate")
    axes[0].vlines(x, bands[:, 0], bands[:, 1], colors="0.5", lw=6, alpha=0.5,
                   label="99 % binomial band for a true 90 %")
    axes[0].axhline(0.9, color="k", ls="--", lw=1)
    axes[0].set_xticks(x, kinds, rotation=30)
    axes[0].set_ylabel("fraction of truths inside the 90 % interval")
    axes[0].set_ylim(0.7, 1.0)
    axes[0].legend(loc="lower left", fontsize=8)
    axes[0].set_title(f"{len(rows)} simulated pairs")
    coh = np.array([r["coherence"] for r in rows])
    frac = np.array([np.mean([v[0] for v in r["checks"].values()]) for r in rows])
    axes[1].semilogx(1 - coh, frac, "k.", ms=6)
    axes[1].axhline(0.9, color="k", ls="--", lw=1)
    axes[1].set_xlabel("1 - coherence (SUT self-noise)")
    axes[1].set_ylabel("fraction inside, per pair")
    axes[1].set_title("coverage against coherence")
    fig.savefig(path, dpi=120)
    plt.close(fig)


if __name__ == "__main__":
    main()
