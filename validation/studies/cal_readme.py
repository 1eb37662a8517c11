"""The README's ``bayescal cal`` example over many seeds: its truth inside
its 95 % intervals, and ``z = (median - truth) / sd`` per parameter.

The run: ``simulate_random_cal(truth=(121, 0.72, 1510), duration=3600,
fs=5, seed=s)`` (an hour at 5 Hz), fitted as ``bayescal cal`` fits it
(``fit_random``, fit lp, seed 0, the default sampler). Beside each fit, the
exact likelihood of the same record with the simulator's noise known (all
18000 samples' DFT bins in the fit's band, the simulator's periodic
construction, so the Gaussian is exact; least squares in ln T, h, ln G and
its Laplace sd): it tells the realisations' own lean from the fit's.
Writes ``validation/results/cal/readme.json``: per seed both z triples,
medians, sds and squared Mahalanobis distances (the fit's under its
samples' covariance, the exact one's under its Laplace covariance) and the
fit's 95 % intervals, and the summary over the first 40 seeds, over seeds
1-10 and over all: the sd ratio fit/exact per parameter, the exact
likelihood's squared Mahalanobis distances summed against chi-square(3n).

    python validation/studies/cal_readme.py --seeds 1 120
"""
from __future__ import annotations

import argparse
import json
import os

import numpy as np
from scipy.optimize import least_squares
from scipy.stats import binom, chi2, norm

from bayescal import coil
from bayescal.coil.random import default_cal_band, fit_random
from bayescal.core.response import paz_velocity_response
from bayescal.simulate.cal import simulate_random_cal
from bayescal.simulate.pair import DIGITIZER_GAIN, NORM_FREQ

TRUTH = (121.0, 0.72, 1510.0)
NAMES = ("period_s", "damping", "gain")
COIL = 1e-9
#: The simulator's defaults behind the README's call: self-noise rms 5 % of
#: the coil signal's (amplitude 1e5 counts), digitizer noise 1 count.
SELF_NOISE = 0.05 * COIL * 1e5
DIGITIZER_NOISE = 1.0


def exact_fit(sim, band):
    """The exact whole-record likelihood's estimate (period, damping, gain),
    its Laplace sds and squared Mahalanobis distance from the truth
    (module docstring)."""
    st = sim.runs["cal"]
    u, x = st[0].data, st[1].data
    n, fs = u.size, st[0].stats.sampling_rate
    f = np.fft.rfftfreq(n, 1.0 / fs)
    sel = (f >= band[0]) & (f <= band[1])
    f, a, y = f[sel], np.fft.rfft(COIL * u)[sel], np.fft.rfft(x)[sel]
    iw = 2j * np.pi * f

    def resp(p):
        return paz_velocity_response(f, *p, digitizer_gain=DIGITIZER_GAIN, norm_freq=NORM_FREQ)

    var = n * (np.abs(resp(TRUTH) / iw) ** 2 * SELF_NOISE ** 2 + DIGITIZER_NOISE ** 2)
    w = np.sqrt(2.0 / var)

    def res(q):
        r = (y - resp((np.exp(q[0]), q[1], np.exp(q[2]))) * a / iw) * w
        return np.r_[r.real, r.imag]

    sol = least_squares(res, [np.log(120.0), 0.707, np.log(1500.0)], x_scale="jac")
    cov = np.linalg.inv(sol.jac.T @ sol.jac)
    est = np.array([np.exp(sol.x[0]), sol.x[1], np.exp(sol.x[2])])
    jac = np.array([est[0], 1.0, est[2]])
    d = est - TRUTH
    cov = cov * np.outer(jac, jac)
    return {"estimate": est.tolist(), "sd": np.sqrt(np.diag(cov)).tolist(),
            "mahalanobis2": float(d @ np.linalg.solve(cov, d))}


def one_seed(seed):
    sim = simulate_random_cal(truth=TRUTH, duration=3600, fs=5, seed=seed)
    run = coil.read_run("U", sim.runs["cal"], sim.inventory, "BC0", "sim")
    fit = fit_random(run, COIL, fit="lp")
    p = fit.summary()["parameters"]
    x = np.column_stack([fit.physical()[k] for k in NAMES])
    d = np.median(x, axis=0) - TRUTH
    ex = exact_fit(sim, default_cal_band(run, "lp"))
    return {"seed": seed,
            "z": [(p[k]["median"] - t) / p[k]["sd"] for k, t in zip(NAMES, TRUTH)],
            "inside_95": [bool(p[k]["ci95"][0] <= t <= p[k]["ci95"][1])
                          for k, t in zip(NAMES, TRUTH)],
            "median": [p[k]["median"] for k in NAMES], "sd": [p[k]["sd"] for k in NAMES],
            "ci95": [p[k]["ci95"] for k in NAMES],
            "mahalanobis2": float(d @ np.linalg.solve(np.cov(x.T), d)),
            "exact_z": [(e - t) / s for e, t, s in zip(ex["estimate"], TRUTH, ex["sd"])],
            "exact": ex}


def summary(rows):
    z, zx = np.array([r["z"] for r in rows]), np.array([r["exact_z"] for r in rows])
    n = len(rows)
    ratio = np.array([r["sd"] for r in rows]) / np.array([r["exact"]["sd"] for r in rows])
    m2 = np.array([r["exact"]["mahalanobis2"] for r in rows])
    return {"seeds": [rows[0]["seed"], rows[-1]["seed"]], "n": n,
            "exact_inside_95": dict(zip(NAMES, (np.abs(zx) < norm.isf(0.025)).sum(0).tolist())),
            "sd_ratio_median": dict(zip(NAMES, np.median(ratio, 0).round(3).tolist())),
            "sd_ratio_range": dict(zip(NAMES, np.c_[ratio.min(0), ratio.max(0)].round(3).tolist())),
            "gain_sd_cv": float(np.std([r["sd"][2] for r in rows], ddof=1)
                                / np.mean([r["sd"][2] for r in rows])),
            "exact_mahalanobis2_sum": float(m2.sum()),
            "chi2_3n_999": float(chi2.isf(0.001, 3 * n)),
            "inside_95": dict(zip(NAMES, np.sum([r["inside_95"] for r in rows], 0).tolist())),
            "binomial_99_band": [int(binom.ppf(0.005, n, 0.95)), int(binom.isf(0.005, n, 0.95))],
            "z_mean": dict(zip(NAMES, z.mean(0).round(3).tolist())),
            "z_sd": dict(zip(NAMES, z.std(0, ddof=1).round(3).tolist())),
            "exact_z_mean": dict(zip(NAMES, zx.mean(0).round(3).tolist())),
            "exact_z_sd": dict(zip(NAMES, zx.std(0, ddof=1).round(3).tolist()))}


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", type=int, nargs=2, default=(1, 40))
    ap.add_argument("--out", default="validation/results/cal/readme.json")
    args = ap.parse_args()
    rows = [one_seed(s) for s in range(args.seeds[0], args.seeds[1] + 1)]
    out = {"truth": TRUTH, "first_10": summary(rows[:10]), "first_40": summary(rows[:40]),
           "all": summary(rows), "runs": rows}
    os.makedirs(os.path.dirname(args.out), exist_ok=True)
    with open(args.out, "w") as fh:
        json.dump(out, fh, indent=1)
    print(json.dumps({k: out[k] for k in ("first_10", "first_40", "all")}, indent=1))


if __name__ == "__main__":
    main()
