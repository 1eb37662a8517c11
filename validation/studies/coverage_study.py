"""Coverage of bayescal's credible intervals over seeded simulated pairs.

For each seed: a random SUT orientation (any azimuth, small dips, a tilted
vertical), random true responses (period, damping, gain off nominal by a few
per cent), a coherence drawn log-uniformly in 1 - coherence from [0.001, 0.1]
(coherence 0.9 to 0.999); the joint posterior (angles and response: 15
parameters) is sampled with the default convergence rule and each truth is
checked against its 90 % interval. Writes a table (``coverage.json``, its
per-seed records in ``coverage.runs.json`` beside it) and a plot into
validation/results/coverage/.

    python validation/studies/coverage_study.py --n 100            # the full study
    python validation/studies/coverage_study.py --n 20 --out /tmp/cov
    python validation/studies/coverage_study.py --n 50 --ref-noise zero --out /tmp/cov0   # noise coefficients held at zero

Truth for a channel's axis is checked as azimuth and dip for horizontals and
as tilt from vertical for the near-vertical channel.
"""
from __future__ import annotations

import argparse
import json
import os
import time

import numpy as np
import study_results                          # the sibling module, run as a script

from bayescal.simulate.coverage import coverage_checks, run_case, summarise

def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--n", type=int, default=100)
    ap.add_argument("--first", type=int, default=0, help="first seed (seeds first .. first+n-1)")
    ap.add_argument("--duration", type=float, default=3600.0)
    ap.add_argument("--fs", type=float, default=10.0)
    ap.add_argument("--band", type=float, nargs=2, default=(0.01, 1.0))
    ap.add_argument("--fit-response", default="all", choices=("none", "gain", "all"))
    ap.add_argument("--out", default="validation/results/coverage")
    ap.add_argument("--ref-noise", default="default", choices=("default", "quiet", "estimate", "zero"),
                    help="the reference's noise treatment: the fit's default, a mode, or 'zero' "
                         "(the errors-in-variables statistic with the noise held at zero: "
                         "--ref-noise-psd of a zero curve)")
    ap.add_argument("--bands-per-decade", type=int, default=None,
                    help="the spectra's bands per decade (default: the pipeline's 6)")
    args = ap.parse_args(argv)
    kw = {}
    if args.ref_noise == "zero":
        period = np.geomspace(0.01, 1e4, 50)
        kw["ref_noise_psd"] = {"*": (period, np.full(period.size, -400.0))}
    elif args.ref_noise != "default":
        kw["ref_noise"] = args.ref_noise
    if args.bands_per_decade is not None:
        if args.bands_per_decade < 1:
            ap.error("--bands-per-decade must be 1 or more")
        import bayescal.pair.preparation as pipeline
        spectra_fn = pipeline.cross_spectra
        pipeline.cross_spectra = lambda *a, **k: spectra_fn(
            *a, **dict(k, bands_per_decade=args.bands_per_decade))
    try:
        return _study(args, kw)
    finally:
        if args.bands_per_decade is not None:
            pipeline.cross_spectra = spectra_fn


def _study(args, kw):
    os.makedirs(args.out, exist_ok=True)
    rows, t0 = [], time.time()
    for seed in range(args.first, args.first + args.n):
        post, azs, dips, resp, coh = run_case(seed, args.duration, args.fs, tuple(args.band),
                                              args.fit_response, **kw)
        checks = coverage_checks(post, azs, dips, resp)
        conv = post.summary()["convergence"]
        rows.append({"seed": seed, "coherence": coh, "checks": checks,
                     "ess_min": conv["ess_min"], "rhat_max": conv["rhat_max"],
                     "converged": conv["converged"]})
        inside = np.mean([v[0] for r in rows for v in r["checks"].values()])
        print(f"[{seed - args.first + 1}/{args.n}] coherence {coh:.4f}  running coverage {inside:.3f}  "
              f"({time.time() - t0:.0f} s)", flush=True)
    table = summarise(rows)
    plot(rows, table, os.path.join(args.out, "coverage.png"))
    study_results.write(os.path.join(args.out, "coverage.json"),
                        {"table": table, "config": vars(args), "seconds": time.time() - t0,
                         "runs": rows})
    print(json.dumps(table, indent=1))


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
