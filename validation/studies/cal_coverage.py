"""Seeded simulation study of ``bayescal cal`` (random kind) with known truth.

* long-period runs (``--fit lp``): PRBS, a few hours at 20 Hz, true period,
  damping and gain a few per cent off nominal;
* high-frequency runs (``--fit hf``): PRBS, 15 minutes at 200 Hz, true
  high-frequency poles (a pair at 50 Hz, a real pole at 70 Hz) a few per cent
  off nominal;
* step runs (``--kind step``): one step on and off, 30 minutes at
  ``--step-fs`` Hz, true period, damping and gain as for the lp runs;
* the same step runs fitted by least squares only (``--n-step-laplace``):
  the Laplace intervals the sampler starts from, a tenth of the cost, so a
  study of a hundred or more runs fits in minutes (at this signal-to-noise
  the posterior is Gaussian: compare the sd with the sampled runs');
* sine runs (``--kind sine``): 15 minutes at 20 Hz, a sine at a frequency
  drawn log-uniformly from 0.02 to 2 Hz, the true response amplitude and phase
  there.

Counts the truths inside the 95 % intervals (with the 99 % binomial band for
a true 95 %) and the median relative error per parameter. Writes
``validation/results/cal/coverage.json``; a kind run with ``--n-KIND 0`` keeps its
section from an existing file (the runs are seeded, so a section does not
change unless its arguments do).

    python validation/studies/cal_coverage.py --n-lp 20 --n-hf 6 --n-step 20 --n-sine 12
"""
from __future__ import annotations

import argparse
import json
import os
import time

import numpy as np
from scipy.stats import binom

from bayescal import coil
from bayescal.coil.random import fit_random
from bayescal.coil.sine import fit_sine
from bayescal.coil.step import fit_step, least_squares_step
from bayescal.core.response import pendulum
from bayescal.simulate.cal import (HF_NOMINAL, LP_NOMINAL, simulate_random_cal,
                                   simulate_sine_cal, simulate_step_cal)

COIL = 1e-9


def lp_case(i, hours, noise_ratio):
    rng = np.random.default_rng(1000 + i)
    t0, h0, g0 = LP_NOMINAL
    truth = (t0 * (1 + 0.03 * rng.standard_normal()), h0 + 0.02 * rng.standard_normal(),
             g0 * (1 + 0.01 * rng.standard_normal()))
    sim = simulate_random_cal(truth=truth, duration=hours * 3600.0, fs=20.0, seed=2000 + i,
                              noise_ratio=noise_ratio)
    run = coil.read_run("U", sim.runs["cal"], sim.inventory, "BC0", "sim")
    s = fit_random(run, COIL, fit="lp", seed=i, n_walkers=16, min_ess=400).summary()
    out = {}
    for p, t in zip(("period_s", "damping", "gain"), truth):
        e = s["parameters"][p]
        out[p] = (e["ci95"][0] <= t <= e["ci95"][1], e["median"] / t - 1, (e["median"] - t) / e["sd"])
    return out, s["convergence"]["converged"]


def _entry(e, t):
    return (e["ci95"][0] <= t <= e["ci95"][1], e["median"] / t - 1, (e["median"] - t) / e["sd"])


def _step_run(i, fs, noise_ratio):
    rng = np.random.default_rng(5000 + i)
    t0, h0, g0 = LP_NOMINAL
    truth = (t0 * (1 + 0.03 * rng.standard_normal()), h0 + 0.02 * rng.standard_normal(),
             g0 * (1 + 0.01 * rng.standard_normal()))
    sim = simulate_step_cal(truth=truth, fs=fs, seed=6000 + i, noise_ratio=noise_ratio)
    return truth, coil.read_run("U", sim.runs["cal"], sim.inventory, "BC0", "sim")


def step_laplace_case(i, fs, noise_ratio):
    """A step run's least-squares point and Laplace 95 % interval (in the
    sampler's c0_rel, c1_rel, ln G, carried to ln T, ln h, ln G)."""
    truth, run = _step_run(i, fs, noise_ratio)
    _, spec, theta, cov = least_squares_step(run, COIL)
    c0, c1 = theta[0], theta[1]
    grad = np.array([[-0.5 / c0, 0.0, 0.0], [-0.5 / c0, 1.0 / c1, 0.0], [0.0, 0.0, 1.0]])
    sd = np.sqrt(np.einsum("ki,ij,kj->k", grad, cov, grad))
    period, damping = pendulum.to_physical(c0, c1, spec.family.period_s, spec.family.damping)
    out = {}
    for j, (p, t, est) in enumerate(zip(("period_s", "damping", "gain"), truth,
                                        (period, damping, np.exp(theta[2])))):
        z = (np.log(est) - np.log(t)) / sd[j]
        out[p] = (bool(abs(z) <= 1.959964), est / t - 1, z)
    return out, True


def step_case(i, fs, noise_ratio):
    truth, run = _step_run(i, fs, noise_ratio)
    s = fit_step(run, COIL, seed=i, n_walkers=16, min_ess=400).summary()
    out = {p: _entry(s["parameters"][p], t)
           for p, t in zip(("period_s", "damping", "gain"), truth)}
    return out, s["convergence"]["converged"]


def sine_case(i, noise_ratio):
    rng = np.random.default_rng(7000 + i)
    t0, h0, g0 = LP_NOMINAL
    truth = (t0 * (1 + 0.03 * rng.standard_normal()), h0 + 0.02 * rng.standard_normal(),
             g0 * (1 + 0.01 * rng.standard_normal()))
    freq = float(np.exp(rng.uniform(np.log(0.02), np.log(2.0))))
    sim = simulate_sine_cal(freq, truth=truth, seed=8000 + i, noise_ratio=noise_ratio)
    run = coil.read_run("U", sim.runs["cal"], sim.inventory, "BC0", "sim")
    s = fit_sine(run, COIL, seed=i, n_walkers=16, min_ess=400).summary()
    h = complex(*sim.truth["response"])
    p = s["parameters"]
    ph = p["response_phase_deg"]
    ph_true = np.degrees(np.angle(h))
    ph_true += 360.0 * np.round((ph["median"] - ph_true) / 360.0)
    out = {"response_amplitude": _entry(p["response_amplitude"], abs(h)),
           "response_phase_deg": (ph["ci95"][0] <= ph_true <= ph["ci95"][1],
                                  (ph["median"] - ph_true) / 360.0, (ph["median"] - ph_true)
                                  / ph["sd"])}
    return out, s["convergence"]["converged"]


def hf_case(i, noise_ratio):
    rng = np.random.default_rng(3000 + i)
    hf_true = tuple(p * (1 + 0.03 * rng.standard_normal() + (0.03j * rng.standard_normal()
                                                              if np.imag(p) else 0))
                    for p in HF_NOMINAL)
    lp = (LP_NOMINAL[0], LP_NOMINAL[1], LP_NOMINAL[2] * (1 + 0.01 * rng.standard_normal()))
    sim = simulate_random_cal(truth=lp, hf_true=hf_true, hf_nominal=HF_NOMINAL, duration=900.0,
                              fs=200.0, seed=4000 + i, noise_ratio=noise_ratio)
    run = coil.read_run("U", sim.runs["cal"], sim.inventory, "BC0", "sim")
    s = fit_random(run, COIL, fit="hf", seed=i, n_walkers=16, min_ess=400).summary()
    out = {}
    e = s["parameters"]["gain"]
    out["gain"] = (e["ci95"][0] <= lp[2] <= e["ci95"][1], e["median"] / lp[2] - 1,
                   (e["median"] - lp[2]) / e["sd"])
    for k, (e, t) in enumerate(zip(s["parameters"]["hf_poles"], hf_true)):
        out[f"pole{k}_re"] = (e["real"]["ci95"][0] <= t.real <= e["real"]["ci95"][1],
                              e["real"]["median"] / t.real - 1, (e["real"]["median"] - t.real)
                              / e["real"]["sd"])
        if e["conjugate_pair"]:
            out[f"pole{k}_im"] = (e["imag"]["ci95"][0] <= t.imag <= e["imag"]["ci95"][1],
                                  e["imag"]["median"] / t.imag - 1,
                                  (e["imag"]["median"] - t.imag) / e["imag"]["sd"])
    return out, s["convergence"]["converged"]


def table(rows):
    out = {}
    for p in rows[0]:
        inside = sum(r[p][0] for r in rows)
        n = len(rows)
        rel = np.array([r[p][1] for r in rows])
        z = np.array([r[p][2] for r in rows])
        out[p] = {"inside_95": int(inside), "n": n,
                  "binomial_99_band": [int(binom.ppf(0.005, n, 0.95)), int(binom.isf(0.005, n, 0.95))],
                  "median_abs_rel_error": float(np.median(np.abs(rel))),
                  "max_abs_rel_error": float(np.max(np.abs(rel))),
                  "z_mean": float(z.mean()), "z_sd": float(z.std(ddof=1)) if n > 1 else None}
    return out


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--n-lp", type=int, default=20)
    ap.add_argument("--n-hf", type=int, default=6)
    ap.add_argument("--n-step", type=int, default=0)
    ap.add_argument("--n-step-laplace", type=int, default=0)
    ap.add_argument("--n-sine", type=int, default=0)
    ap.add_argument("--step-fs", type=float, default=20.0)
    ap.add_argument("--step-noise-ratio", type=float, default=0.01,
                    help="step and sine runs: self-noise rms over the signal's acceleration "
                         "(default 0.01)")
    ap.add_argument("--hours", type=float, default=3.0)
    ap.add_argument("--noise-ratio", type=float, default=0.05,
                    help="sensor self-noise rms over the coil signal's rms (default 0.05)")
    ap.add_argument("--out", default="validation/results/cal")
    args = ap.parse_args()
    path = os.path.join(args.out, "coverage.json")
    previous = {}
    if os.path.exists(path):
        with open(path) as fh:
            previous = json.load(fh)
    kinds = {"lp": (args.n_lp, lambda i: lp_case(i, args.hours, args.noise_ratio)),
             "hf": (args.n_hf, lambda i: hf_case(i, args.noise_ratio)),
             "step": (args.n_step, lambda i: step_case(i, args.step_fs, args.step_noise_ratio)),
             "step_laplace": (args.n_step_laplace,
                              lambda i: step_laplace_case(i, args.step_fs, args.step_noise_ratio)),
             "sine": (args.n_sine, lambda i: sine_case(i, args.step_noise_ratio))}
    result = {"sections": previous.get("sections", {})}
    if "lp" in previous and "sections" not in previous:      # the first layout of this file
        result["sections"] = {k: {"table": previous[k], "args": previous["args"],
                                  "seconds": previous["seconds"][k],
                                  "converged": (f"{previous['converged']} of "
                                                f"{previous['runs']} (lp and hf together)"),
                                  "runs": previous["args"][f"n_{k}"]}
                              for k in ("lp", "hf")}
    for kind, (n, case) in kinds.items():
        if n == 0:
            continue
        t = time.time()
        rows = [case(i) for i in range(n)]
        result["sections"][kind] = {"table": table([r for r, _ in rows]),
                                    "converged": int(sum(c for _, c in rows)), "runs": n,
                                    "seconds": time.time() - t, "args": vars(args)}
        print(kind, json.dumps(result["sections"][kind]["table"], indent=1), flush=True)
    os.makedirs(args.out, exist_ok=True)
    with open(path, "w") as fh:
        json.dump(result, fh, indent=2)


if __name__ == "__main__":
    main()
