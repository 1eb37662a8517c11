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

* simulation-based calibration (``--sbc N``, the proof of issue 41's item
  1): per kind (random lp, random hf, step, sine) N runs, the truth of run i
  drawn from the stated prior (period and damping log-normal, 5 % around
  nominal; gain log-uniform, drawn within a factor 2 of nominal, where the
  stated factor-10 prior is as flat in ln G as anywhere; the hf poles'
  coordinates uniform within 5 % of nominal, inside their uniform +-50 %
  prior), the run's length (random lp: 1-4 h; hf 10 min at 100 Hz; step
  30 min; sine 15 min), its self-noise white or coloured (PSD as 1/f in
  acceleration) and its input channel recorded exactly or with white noise
  of 1 % of the drive's amplitude, all four combinations in turn (run i:
  colour ``i % 2``, input noise ``(i // 2) % 2``). Low sampling rates (lp and
  step 5 Hz, sine 10 Hz) and short sampler settings (``--sbc-walkers`` 16,
  ``--sbc-ess`` 200) keep a run cheap. Per parameter: the rank of the truth
  among the posterior samples (its fraction below the truth, 10 bins), and
  ``z = (median - truth) / sd``; each histogram bin, the z mean and the z
  sd against their level-0.001 bands (bins Bonferroni over the 10).
  Each run's row is appended to ``validation/results/cal/sbc_runs.jsonl`` as
  it finishes (a rerun skips the rows there: resumable); the tables go to
  ``validation/results/cal/sbc.json``.

Counts the truths inside the 95 % intervals (with the 99 % binomial band for
a true 95 %) and the median relative error per parameter. Writes
``validation/results/cal/coverage.json``; a kind run with ``--n-KIND 0`` keeps its
section from an existing file (the runs are seeded, so a section does not
change unless its arguments do).

    python validation/studies/cal_coverage.py --n-lp 20 --n-hf 6 --n-step 20 --n-sine 12
    python validation/studies/cal_coverage.py --n-lp 0 --n-hf 0 --sbc 200
"""
from __future__ import annotations

import argparse
import json
import os
import time

import numpy as np
from scipy.stats import binom, chi2, norm

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


# --- simulation-based calibration ---------------------------------------------

#: The study's kinds, in the order they run.
SBC_KINDS = ("random_lp", "sine", "random_hf", "step")
#: Input-channel noise of the runs with it on (rms over the drive's amplitude).
SBC_INPUT_NOISE = 0.01
#: Self-noise PSD slope of the coloured runs (acceleration, 1/f).
SBC_SLOPE = 1.0


def sbc_truth(rng, hf=False):
    """(period, damping, gain) from the stated prior (module docstring) and,
    with ``hf``, the hf poles."""
    t0, h0, g0 = LP_NOMINAL
    lp = (t0 * np.exp(0.05 * rng.standard_normal()), h0 * np.exp(0.05 * rng.standard_normal()),
          g0 * np.exp(rng.uniform(-np.log(2.0), np.log(2.0))))
    if not hf:
        return lp, ()
    poles = tuple(complex(p.real * (1 + rng.uniform(-0.05, 0.05)),
                          p.imag * (1 + rng.uniform(-0.05, 0.05))) for p in map(complex, HF_NOMINAL))
    return (t0, h0, lp[2]), poles


def _rank_row(samples, truth):
    """(fraction of samples below truth, median, sd, inside the 95 % interval)."""
    lo, hi = np.percentile(samples, [2.5, 97.5])
    return {"rank": float(np.mean(samples < truth)), "median": float(np.median(samples)),
            "sd": float(np.std(samples, ddof=1)), "truth": float(truth),
            "in95": bool(lo <= truth <= hi)}


def sbc_run(kind, i, walkers, ess):
    """One seeded run of ``kind``: its configuration and per-parameter rows."""
    rng = np.random.default_rng(90_000 + 1000 * SBC_KINDS.index(kind) + i)
    cfg = {"slope": SBC_SLOPE * (i % 2), "input_noise": SBC_INPUT_NOISE * ((i // 2) % 2)}
    noise = dict(noise_slope=cfg["slope"], input_noise=cfg["input_noise"], seed=100_000 + i)
    kw = dict(seed=i, n_walkers=walkers, min_ess=ess)
    lp, poles = sbc_truth(rng, hf=kind == "random_hf")
    if kind == "random_lp":
        cfg["hours"] = float(rng.uniform(1.0, 4.0))
        sim = simulate_random_cal(truth=lp, duration=round(cfg["hours"] * 3600.0), fs=5.0,
                                  **noise)
        fit = fit_random(_read(sim), COIL, fit="lp", **kw)
    elif kind == "random_hf":
        sim = simulate_random_cal(truth=lp, hf_true=poles, hf_nominal=HF_NOMINAL, duration=600.0,
                                  fs=100.0, **noise)
        fit = fit_random(_read(sim), COIL, fit="hf", **kw)
    elif kind == "step":
        sim = simulate_step_cal(truth=lp, fs=5.0, noise_ratio=0.01, **noise)
        fit = fit_step(_read(sim), COIL, **kw)
    else:
        cfg["freq_hz"] = float(np.exp(rng.uniform(np.log(0.02), np.log(2.0))))
        sim = simulate_sine_cal(cfg["freq_hz"], truth=lp, fs=10.0, noise_ratio=0.01, **noise)
        fit = fit_sine(_read(sim), COIL, **kw)
    phys = fit.physical()
    if kind == "sine":
        h = complex(*sim.truth["response"])
        ph = np.degrees(np.angle(h))
        ph += 360.0 * np.round((np.median(phys["response_phase_deg"]) - ph) / 360.0)
        rows = {"response_amplitude": _rank_row(phys["response_amplitude"], abs(h)),
                "response_phase_deg": _rank_row(phys["response_phase_deg"], ph)}
    else:
        rows = {"gain": _rank_row(phys["gain"], lp[2])}
        if kind != "random_hf":
            rows["period_s"] = _rank_row(phys["period_s"], lp[0])
            rows["damping"] = _rank_row(phys["damping"], lp[1])
        for k, p in enumerate(poles):
            rows[f"pole{k}_re"] = _rank_row(phys["hf"][:, k].real, p.real)
            if p.imag:
                rows[f"pole{k}_im"] = _rank_row(phys["hf"][:, k].imag, p.imag)
    return {"kind": kind, "i": i, "config": cfg, "converged": bool(fit.convergence.converged),
            "parameters": rows}


def _read(sim):
    return coil.read_run("U", sim.runs["cal"], sim.inventory, "BC0", "sim")


def sbc_bands(n, bins=10, level=0.001):
    """Level-``level`` bands for ``n`` runs: z mean, z sd (chi-square) and
    each rank bin's count (binomial, Bonferroni over the bins)."""
    q = norm.isf(level / 2)
    a = level / bins
    return {"z_mean": [-q / np.sqrt(n), q / np.sqrt(n)],
            "z_sd": [float(np.sqrt(chi2.ppf(level / 2, n - 1) / (n - 1))),
                     float(np.sqrt(chi2.isf(level / 2, n - 1) / (n - 1)))],
            "rank_bin": [int(binom.ppf(a / 2, n, 1 / bins)), int(binom.isf(a / 2, n, 1 / bins))]}


def sbc_table(rows, bins=10):
    """Per kind and parameter: rank histogram, z mean and sd, coverage, and
    whether each is inside its level-0.001 band."""
    out = {}
    for kind in SBC_KINDS:
        runs = [r for r in rows if r["kind"] == kind]
        if len(runs) < 2:
            continue
        band = sbc_bands(len(runs), bins)
        sec = {"runs": len(runs), "converged": int(sum(r["converged"] for r in runs)),
               "bands": band, "parameters": {}}
        for p in runs[0]["parameters"]:
            e = [r["parameters"][p] for r in runs]
            z = np.array([(x["median"] - x["truth"]) / x["sd"] for x in e])
            hist = np.histogram([x["rank"] for x in e], bins=bins, range=(0, 1))[0]
            zm, zs = float(z.mean()), float(z.std(ddof=1))
            sec["parameters"][p] = {
                "rank_histogram": hist.tolist(), "z_mean": zm, "z_sd": zs,
                "inside_95": int(sum(x["in95"] for x in e)),
                "ranks_ok": bool(hist.min() >= band["rank_bin"][0]
                                 and hist.max() <= band["rank_bin"][1]),
                "z_mean_ok": bool(band["z_mean"][0] <= zm <= band["z_mean"][1]),
                "z_sd_ok": bool(band["z_sd"][0] <= zs <= band["z_sd"][1])}
        out[kind] = sec
    return out


def run_sbc(n, out, walkers, ess, kinds=SBC_KINDS):
    """Run (or resume) the study, appending rows; write the tables."""
    path = os.path.join(out, "sbc_runs.jsonl")
    os.makedirs(out, exist_ok=True)
    rows = []
    if os.path.exists(path):
        with open(path) as fh:
            rows = [json.loads(line) for line in fh if line.strip()]
    done = {(r["kind"], r["i"]) for r in rows}
    for kind in kinds:
        for i in range(n):
            if (kind, i) in done:
                continue
            t = time.time()
            row = sbc_run(kind, i, walkers, ess)
            row["seconds"] = time.time() - t
            rows.append(row)
            with open(path, "a") as fh:
                fh.write(json.dumps(row) + "\n")
    write_sbc(rows, out, walkers, ess)


def write_sbc(rows, out, walkers, ess):
    """Write ``sbc.json``: the tables, the settings and the time per run."""
    table = sbc_table(rows)
    for kind, sec in table.items():
        sec["seconds_per_run"] = float(np.mean([r["seconds"] for r in rows if r["kind"] == kind]))
    with open(os.path.join(out, "sbc.json"), "w") as fh:
        json.dump({"sampler": {"n_walkers": walkers, "min_ess": ess},
                   "input_noise": SBC_INPUT_NOISE, "slope": SBC_SLOPE, "kinds": table}, fh,
                  indent=1)
    print(json.dumps(table, indent=1))


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
    ap.add_argument("--sbc", type=int, default=0, help="simulation-based calibration: runs per "
                    "kind (module docstring)")
    ap.add_argument("--sbc-kinds", nargs="+", default=list(SBC_KINDS), choices=SBC_KINDS)
    ap.add_argument("--sbc-walkers", type=int, default=16)
    ap.add_argument("--sbc-ess", type=int, default=200)
    args = ap.parse_args()
    if args.sbc:
        run_sbc(args.sbc, args.out, args.sbc_walkers, args.sbc_ess, args.sbc_kinds)
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
