"""Errors-in-variables study: gain and azimuth standardised errors of the
least-squares fit (Laplace intervals) for the reference-quiet model and the
errors-in-variables modes, over regimes of the reference's self-noise.

Each pair: 1 h at 10 Hz, band 0.02-1 Hz, SUT at a random azimuth, gains off
their metadata by up to 3 %, self-noise white in counts and the same on every
channel of a sensor (SUT 30 s, reference 120 s nominal responses), seeded.

    python validation/studies/eiv_study.py --n 12        # about 2 minutes per mode and regime

Writes validation/results/eiv/study.json and prints the table quoted in the README.

With ``--mcmc`` the posterior is sampled as ``bayescal fit`` does, over
regimes of noise ratio and pair coherence (``validation/studies/eiv_coverage.py``);
seeds ``--seed0 .. --seed0 + n - 1`` per regime, rows appended to
``validation/results/eiv/coverage.json`` (so chunks run one after another add up), and
the per-regime, per-kind table printed:

    python validation/studies/eiv_study.py --mcmc --fit gain --modes estimate --n 3
    python validation/studies/eiv_study.py --mcmc --fit all --modes estimate --n 2
    python validation/studies/eiv_study.py --mcmc --table      # the table of what is there
"""
from __future__ import annotations

import argparse
import json
import os
import sys
import time

import numpy as np

from bayescal.core.fit.run import build_model, least_squares_fit
from bayescal.core.spectra.welch import cross_spectra
from bayescal.io.align import align
from bayescal.simulate import simulate_pair

import study_results                                   # the sibling module, run as a script
from eiv_coverage import run_pair, summarise, table    # the sibling study, run as a script

#: (label, SUT coherence, reference coherence): reference noise-free, as noisy
#: as the SUT, ten times noisier.
REGIMES = (("ref noise-free, coh 0.9", 0.9, 0.9999), ("equal noise, coh 0.9", 0.9, 0.9),
           ("ref 10x noisier, coh 0.99", 0.99, 0.908), ("ref 10x noisier, coh 0.999", 0.999, 0.99))


def one(mode, seed, coherence, ref_coherence, two=False):
    rng = np.random.default_rng(1000 + seed)
    gains = 750 * (1 + rng.uniform(-0.03, 0.03, 3))
    az = rng.uniform(0, 360)
    sim = simulate_pair(duration=3600, fs=10, seed=seed, coherence=coherence,
                        ref_coherence=ref_coherence, sut_azimuth=(az, az + 90, 0),
                        sut_dip=(0, 0, -90), noise_in_counts=True,
                        sut_response=tuple((30.0, 0.707, g) for g in gains))
    sut, ref = sim.sut, sim.ref
    if two:           # a 2+2 pair: the horizontals only
        sut, ref = sut.select(channel="BH[12]"), ref.select(channel="BH[NE]")
    s, r, fs, _ = align(sut, sim.sut_inventory, ref, sim.ref_inventory)
    sp = cross_spectra(s.data, r.data, fs, s.response_fn(), r.response_fn(), (0.02, 1.0),
                       sut_ids=s.ids, ref_ids=r.ids)
    setup = build_model(sp, r.vectors, s.vectors, s.families(), "gain", ref_noise=mode)
    m = setup.model
    th, cov = least_squares_fit(m, setup.theta0)
    gi = [i for i, nm in enumerate(m.names) if nm.endswith("log_gain")]
    zg = [(th[i] - np.log(gains[j])) / np.sqrt(cov[i, i]) for j, i in enumerate(gi)]

    def azimuth(t):
        v = m.unpack(t[None])[0][0, 0]
        return np.degrees(np.arctan2(v[1], v[0]))
    grad = np.zeros(th.size)
    for i in (0, 1):
        d = np.zeros(th.size)
        d[i] = 1e-6
        grad[i] = (azimuth(th + d) - azimuth(th - d)) / 2e-6
    za = ((azimuth(th) - az + 180) % 360 - 180) / np.sqrt(grad @ cov @ grad)
    return zg, [za]


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--n", type=int, default=12, help="pairs per mode and regime")
    ap.add_argument("--modes", nargs="+", default=["quiet", "estimate"])
    ap.add_argument("--out", default=None, help="validation/results/eiv/study.json or coverage.json")
    ap.add_argument("--mcmc", action="store_true", help="MCMC coverage over regimes")
    ap.add_argument("--fit", default="gain", choices=["gain", "all"])
    ap.add_argument("--ratios", nargs="+", type=float, default=[0.0, 1.0, 10.0])
    ap.add_argument("--coherences", nargs="+", type=float, default=[0.9, 0.99, 0.999])
    ap.add_argument("--seed0", type=int, default=0)
    ap.add_argument("--two-by-two", action="store_true", help="horizontals only (2+2 pairs)")
    ap.add_argument("--table", action="store_true", help="with --mcmc: print the table only")
    ap.add_argument("--duration", type=float, default=3600.0,
                    help="with --mcmc: record length in seconds (default 3600, at 10 Hz)")
    ap.add_argument("--signal-noise", action="store_true",
                    help="with --mcmc: self-noise a fixed share of each channel's signal (the "
                         "simulator's default, outside mode estimate's model) instead of white "
                         "in counts")
    args = ap.parse_args()
    if args.mcmc:
        return mcmc(args)
    args.out = args.out or "validation/results/eiv/study.json"
    rows = []
    print(f"{'regime':28s} {'mode':9s} {'gain z mean':>11s} {'sd':>5s} {'in 90%':>7s} "
          f"{'az z mean':>9s} {'sd':>5s} {'in 90%':>7s}")
    for label, coh, refc in REGIMES:
        for mode in args.modes:
            t0 = time.time()
            zg, za = [], []
            for seed in range(args.seed0, args.seed0 + args.n):
                g, a = one(mode, seed, coh, refc, args.two_by_two)
                zg += g
                za += a
            zg, za = np.array(zg), np.array(za)
            row = {"regime": label, "coherence": coh, "ref_coherence": refc, "mode": mode,
                   "n_pairs": args.n, "gain_z_mean": zg.mean(), "gain_z_sd": zg.std(ddof=1),
                   "gain_in90": int(np.sum(np.abs(zg) < 1.645)), "gain_n": zg.size,
                   "az_z_mean": za.mean(), "az_z_sd": za.std(ddof=1),
                   "az_in90": int(np.sum(np.abs(za) < 1.645)), "az_n": za.size,
                   "seconds": time.time() - t0}
            rows.append(row)
            print(f"{label:28s} {mode:9s} {row['gain_z_mean']:+11.2f} {row['gain_z_sd']:5.2f} "
                  f"{row['gain_in90']:3d}/{zg.size:<3d} {row['az_z_mean']:+9.2f} "
                  f"{row['az_z_sd']:5.2f} {row['az_in90']:3d}/{za.size:<3d}", flush=True)
    os.makedirs(os.path.dirname(args.out), exist_ok=True)
    with open(args.out, "w") as fh:
        json.dump({"command": "python validation/studies/eiv_study.py --n %d --seed0 %d" % (args.n, args.seed0),
                   "rows": rows},
                  fh, indent=1)


def mcmc(args):
    """Coverage rows appended to ``args.out`` and the summary table printed."""
    out = args.out or "validation/results/eiv/coverage.json"
    # earlier chunks' rows: from the per-run file (the summary alone has none)
    old = study_results.read(out) if study_results.runs_path(out).exists() else {}
    rows = old.get("rows", [])
    commands = old.get("commands", [old["command"]] if "command" in old else [])
    if not args.table:
        commands.append("python validation/studies/eiv_study.py " + " ".join(sys.argv[1:]))
    noise = "signal" if args.signal_noise else "counts"
    done = {(r["seed"], r["ratio"], r["pair_coherence"], r["fit"], r["mode"],
             r.get("noise", "counts"), r.get("duration_s", 3600.0)) for r in rows}
    for ratio in [] if args.table else args.ratios:
        for coh in args.coherences:
            for mode in args.modes:
                for seed in range(args.seed0, args.seed0 + args.n):
                    if (seed, ratio, coh, args.fit, mode, noise, args.duration) in done:
                        continue
                    r = run_pair(seed, ratio, coh, args.fit, mode, duration=args.duration,
                                 noise_in_counts=not args.signal_noise)
                    rows.append(r)
                    print(f"ratio {ratio:g} coh {coh} {args.fit} {mode} {noise} seed {seed}: "
                          f"{r['cpu_s']:.1f} s cpu, converged {r['converged']}", flush=True)
                    study_results.write(out, {"commands": commands, "rows": rows,
                                              "summary": summarise(rows)})
    summary = summarise(rows)
    print(table(summary))
    cpu = {}
    for r in rows:
        cpu.setdefault((r["fit"], r["mode"]), []).append(r["cpu_s"])
    for k, v in sorted(cpu.items()):
        print(f"cpu per fit {k[0]} {k[1]}: median {np.median(v):.1f} s over {len(v)}")
    print(f"converged {sum(r['converged'] for r in rows)} / {len(rows)}")


if __name__ == "__main__":
    main()
