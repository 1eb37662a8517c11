"""Coverage of the UVW element intervals over seeded simulations.

For each seed: draw true element parameters around the STS-2 nominal, simulate
coil-by-coil runs (bayescal.simulate.coil), fit one element (cycling U, V, W) from
all outputs and from Z only, and record whether the truth lies in the 68, 90
and 95 % intervals. Prints the covered fractions with Clopper-Pearson 95 %
binomial intervals, recovery errors and the time per fit.

    .venv/bin/python validation/studies/uvw_coverage.py --n 120 --out validation/results/uvw/coverage.json
"""
from __future__ import annotations

import argparse
import json
import os
import time

import numpy as np
from scipy.stats import binomtest

from bayescal import coil
from bayescal.simulate.coil import STS2_NOMINAL, simulate_calibration

LEVELS = ("ci68", "ci90", "ci95")


def draw_elements(rng):
    """True (period, damping, gain) of U, V, W scattered around nominal."""
    t0, h0, g0 = STS2_NOMINAL
    return tuple((t0 * (1 + 0.03 * rng.standard_normal()), h0 + 0.02 * rng.standard_normal(),
                  g0 * (1 + 0.01 * rng.standard_normal())) for _ in range(3))


def one(seed, duration, band, modes, nperseg=None):
    """Fit one element of one simulation; returns a record per mode."""
    rng = np.random.default_rng(1000 + seed)
    els = draw_elements(rng)
    sim = simulate_calibration(elements=els, seed=seed, duration=duration)
    e = coil.ELEMENTS[seed % 3]
    run = coil.read_run(e, sim.runs[e], sim.inventory, "BC0", f"sim{seed}:{e}")
    truth = dict(zip(coil.PARAMS, els[coil.ELEMENTS.index(e)]))
    out = {}
    for mode in modes:
        r = run.select(["Z"]) if mode == "z" else run
        t = time.perf_counter()
        fit = coil.fit_run(r, coil.STS2_UVW, sim.truth["coil_constant"], band, nperseg=nperseg,
                          seed=seed)
        dt = time.perf_counter() - t
        s = fit.summary()
        out[mode] = {"time_s": dt, "element": e, "steps": fit.convergence.n_steps,
                     "samples": fit.samples,
                     **{p: {"truth": truth[p], "median": s[p]["median"], "sd": s[p]["sd"],
                            **{lv: bool(s[p][lv][0] <= truth[p] <= s[p][lv][1]) for lv in LEVELS}}
                        for p in coil.PARAMS}}
    return out


def _agreement_z(a, z, j):
    from types import SimpleNamespace
    ag = coil.agreement(SimpleNamespace(samples=a), SimpleNamespace(samples=z))
    return ag[coil.PARAMS[j]]["z"]


def summarise(records, mode):
    """Covered fractions with binomial intervals, recovery errors, times."""
    rec = [r[mode] for r in records]
    n = len(rec)
    cov = {}
    for p in coil.PARAMS:
        cov[p] = {}
        for lv in LEVELS:
            k = sum(r[p][lv] for r in rec)
            ci = binomtest(k, n).proportion_ci(0.95)
            cov[p][lv] = {"covered": k, "n": n, "fraction": k / n, "ci95": [ci.low, ci.high]}
        err = np.array([abs(r[p]["median"] - r[p]["truth"]) / abs(r[p]["truth"]) for r in rec])
        cov[p]["relative_error"] = {"median": float(np.median(err)), "max": float(err.max())}
        z = np.array([(r[p]["median"] - r[p]["truth"]) / r[p]["sd"] for r in rec])
        cov[p]["standardised_error"] = {"mean": float(z.mean()), "sd": float(z.std()),
                                        "mean_se": float(z.std() / np.sqrt(n))}
    times = np.array([r["time_s"] for r in rec])
    if mode == "all" and "z" in records[0]:
        # Z-only vs all-output agreement statistic (coil.agreement) under the
        # true model: should be about standard normal
        zs = np.array([[_agreement_z(r["all"]["samples"], r["z"]["samples"], j)
                        for j in range(3)] for r in records])
        cov["agreement_z"] = {"sd": zs.std(axis=0).tolist(),
                              "fraction_abs_above_3": float(np.mean(np.abs(zs) > 3)),
                              "max_abs": float(np.abs(zs).max())}
    return {"coverage": cov, "time_per_fit_s": {"median": float(np.median(times)),
                                                 "max": float(times.max())}}


def main():
    ap = argparse.ArgumentParser(description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--n", type=int, default=60, help="number of simulations")
    ap.add_argument("--duration", type=float, default=8 * 3600.0, help="record per run (s)")
    ap.add_argument("--band", nargs=2, type=float, default=(0.5 / 120, 25 / 120))
    ap.add_argument("--modes", default="all,z", help="all and/or z")
    ap.add_argument("--nperseg", type=int, default=None,
                    help="segment length (samples); default: bayescal.coil.uvw's choice")
    ap.add_argument("--out", default=None, help="write the summary JSON here")
    args = ap.parse_args()
    modes = args.modes.split(",")
    t0 = time.perf_counter()
    records = []
    for s in range(args.n):
        records.append(one(s, args.duration, tuple(args.band), modes, args.nperseg))
        print(f"simulation {s + 1}/{args.n} done, {time.perf_counter() - t0:.0f} s", flush=True)
    result = {"n": args.n, "duration_s": args.duration, "band_hz": list(args.band),
              "nperseg": args.nperseg,
              "wall_s": time.perf_counter() - t0,
              **{mode: summarise(records, mode) for mode in modes}}
    for mode in modes:
        print(f"mode {mode}:")
        for p, c in result[mode]["coverage"].items():
            if p == "agreement_z":
                print(f"  Z-only vs all-output z: sd per parameter {np.round(c['sd'], 2).tolist()}, "
                      f"|z|>3 in {100 * c['fraction_abs_above_3']:.1f} %")
                continue
            levels = "  ".join(f"{lv} {c[lv]['covered']}/{c[lv]['n']} "
                               f"[{c[lv]['ci95'][0]:.2f}, {c[lv]['ci95'][1]:.2f}]" for lv in LEVELS)
            print(f"  {p:9s} {levels}  rel. error median {c['relative_error']['median']:.2e} "
                  f"max {c['relative_error']['max']:.2e}; (median-truth)/sd mean "
                  f"{c['standardised_error']['mean']:+.2f} +- {c['standardised_error']['mean_se']:.2f}"
                  f" sd {c['standardised_error']['sd']:.2f}")
        print(f"  time per fit: median {result[mode]['time_per_fit_s']['median']:.1f} s")
    if args.out:
        os.makedirs(os.path.dirname(os.path.abspath(args.out)), exist_ok=True)
        with open(args.out, "w") as fh:
            json.dump(result, fh, indent=2, default=float)


if __name__ == "__main__":
    main()
