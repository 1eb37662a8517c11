"""The README's ``bayescal cal`` run (seed 1) with its input kept and its
noise drawn afresh: is the fit's interval on that input as wide as its
median's scatter, and is seed 1's miss a tail event?

The input of ``simulate_random_cal(truth=(121, 0.72, 1510), duration=3600,
fs=5, seed=1)`` is kept; each replica draws the output's noise again from
the simulator's law (white self-noise in acceleration, rms 5 % of the coil
signal's, and white digitizer noise of 1 count; drawn here with numpy, not
by the simulator) and is fitted as ``bayescal cal`` fits it, beside the
exact whole-record likelihood of ``cal_readme.py``. Over the replicas, per
parameter: the sd of the fit's median against the mean of its posterior sd
(the frequentist check of the interval's width on this input, no prior
involved: the prior is wide against these sds), the same for the exact
likelihood, and the regression of the fit's error on the exact one's
(efficient estimate plus independent excess: slope 1). Seed 1's own z are
read from ``readme.json`` beside the tail probabilities they imply.

Where the fit's information goes (noise known, Fisher information of the
whole record's DFT bins in the fit's band, closed form): per bin (the exact
likelihood's), the bins summed over each of the fit's bands weighted by the
input over the nominal response (the statistic the fit's band residual
is), and both on the span of
the record the fit's segments cover (information in proportion to the
span: the deconvolution's edges left out).

    python validation/studies/cal_readme_replicas.py --n 60
"""
from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path
from types import SimpleNamespace

import numpy as np
from scipy.stats import binom, chi2, norm

sys.path.insert(0, str(Path(__file__).resolve().parent))
import study_results  # noqa: E402
from cal_readme import COIL, DIGITIZER_NOISE, NAMES, SELF_NOISE, TRUTH, exact_fit  # noqa: E402

from bayescal import coil  # noqa: E402
from bayescal.coil.element import run_spectra  # noqa: E402
from bayescal.coil.random import default_cal_band, fit_random  # noqa: E402
from bayescal.core.response import paz_velocity_response  # noqa: E402
from bayescal.simulate.cal import simulate_random_cal  # noqa: E402
from bayescal.simulate.pair import DIGITIZER_GAIN, NORM_FREQ  # noqa: E402


def replica(sim, rng):
    """``sim`` with its output drawn again: the same input, fresh noise."""
    st = sim.runs["cal"].copy()
    u = st[0].data
    n, fs = u.size, st[0].stats.sampling_rate
    f = np.fft.rfftfreq(n, 1.0 / fs)
    iw = 2j * np.pi * f
    iw[0] = np.inf
    k = paz_velocity_response(f, *TRUTH, digitizer_gain=DIGITIZER_GAIN, norm_freq=NORM_FREQ)
    noise = np.fft.rfft(SELF_NOISE * rng.standard_normal(n))
    st[1].data = np.fft.irfft(k * (np.fft.rfft(COIL * u) + noise) / iw, n=n) \
        + DIGITIZER_NOISE * rng.standard_normal(n)
    return SimpleNamespace(runs={"cal": st}, inventory=sim.inventory)


def marginal_sd(jac_rows, weights):
    """Marginal sds of (period, damping, gain) from the Fisher information
    ``sum_k w_k 2 Re(conj(d_i) d_j)`` of complex observations whose
    derivatives in (ln T, h, ln G) are the rows of ``jac_rows`` (K, 3)."""
    info = 2 * np.real(jac_rows.conj().T @ (jac_rows * weights[:, None]))
    sd = np.sqrt(np.diag(np.linalg.inv(info)))
    return sd * np.array([TRUTH[0], 1.0, TRUTH[2]])


def information(sim):
    """Marginal sds per bin, per band, and those with the edges left out
    (module docstring)."""
    st = sim.runs["cal"]
    u, n, fs = st[0].data, st[0].stats.npts, st[0].stats.sampling_rate
    run = coil.read_run("U", st, sim.inventory, "BC0", "sim")
    band = default_cal_band(run, "lp")
    sp = run_spectra(run, COIL, band)
    f = np.fft.rfftfreq(n, 1.0 / fs)
    sel = (f >= band[0]) & (f <= band[1])
    f, a = f[sel], np.fft.rfft(COIL * u)[sel] / (2j * np.pi * f[sel])
    q0, eps = np.array([np.log(TRUTH[0]), TRUTH[1], np.log(TRUTH[2])]), 1e-6

    def resp(q):
        return paz_velocity_response(f, np.exp(q[0]), q[1], np.exp(q[2]),
                                     digitizer_gain=DIGITIZER_GAIN, norm_freq=NORM_FREQ)

    d = np.column_stack([(resp(q0 + eps * e) - resp(q0 - eps * e)) / (2 * eps)
                         for e in np.eye(3)]) * a[:, None]                 # d(H A)/dq
    var = n * (np.abs(resp(q0) / (2 * np.pi * f)) ** 2 * SELF_NOISE ** 2
               + DIGITIZER_NOISE ** 2)
    per_bin = marginal_sd(d, 1.0 / var)
    # the fit's bands on this grid: edges half-way between their outer bins
    last = np.array([sp.freqs[sp.band_of == b].max() for b in range(sp.n_bands)])
    of = np.searchsorted(0.5 * (last[:-1] + np.array([sp.freqs[sp.band_of == b].min()
                                                      for b in range(1, sp.n_bands)])), f)
    # the fit sums the output deconvolved by the nominal response
    w = np.conj(a) / run.nominal_response(f)[0]
    summed = np.array([(w[of == b, None] * d[of == b]).sum(0) for b in range(sp.n_bands)])
    bvar = np.bincount(of, np.abs(w) ** 2 * var, minlength=sp.n_bands)
    per_band = marginal_sd(summed, 1.0 / bvar)
    span = (sp.segment_starts[-1] + sp.nperseg - sp.segment_starts[0]) / n
    return {"per_bin_sd": dict(zip(NAMES, per_bin.tolist())),
            "per_band_sd": dict(zip(NAMES, per_band.tolist())),
            "span_fraction": float(span), "n_bands": int(sp.n_bands),
            "band_over_bin": dict(zip(NAMES, (per_band / per_bin).tolist())),
            "edges_over_whole": float(1 / np.sqrt(span)),
            "band_and_edges_over_bin": dict(zip(NAMES, (per_band / per_bin / np.sqrt(span))
                                                .tolist()))}


def one(sim, rng):
    rep = replica(sim, rng)
    run = coil.read_run("U", rep.runs["cal"], rep.inventory, "BC0", "sim")
    p = fit_random(run, COIL, fit="lp").summary()["parameters"]
    ex = exact_fit(rep, default_cal_band(run, "lp"))
    return {"median": [p[k]["median"] for k in NAMES], "sd": [p[k]["sd"] for k in NAMES],
            "inside_95": [bool(p[k]["ci95"][0] <= t <= p[k]["ci95"][1])
                          for k, t in zip(NAMES, TRUTH)],
            "exact": ex["estimate"], "exact_sd": ex["sd"]}


def summary(rows, seed_run):
    med, sd = np.array([r["median"] for r in rows]), np.array([r["sd"] for r in rows])
    ex, exsd = np.array([r["exact"] for r in rows]), np.array([r["exact_sd"] for r in rows])
    err, exerr = med - TRUTH, ex - TRUTH
    slope = (err * exerr).sum(0) / (exerr ** 2).sum(0)
    excess = (err - slope * exerr).std(0, ddof=1)
    zx1, z1 = np.array(seed_run["exact_z"]), np.array(seed_run["z"])
    # the fit's z of seed 1 given its exact error: the regression's prediction
    pred = slope * zx1 * exsd.mean(0)
    p_cond = norm.cdf(-np.abs(z1 * sd.mean(0) - pred) / excess)
    n = len(rows)
    out = {"n": n,
           "fit_median_scatter": dict(zip(NAMES, med.std(0, ddof=1).tolist())),
           "fit_sd_mean": dict(zip(NAMES, sd.mean(0).tolist())),
           "fit_scatter_over_sd": dict(zip(NAMES, (med.std(0, ddof=1) / sd.mean(0)).tolist())),
           "fit_sd_cv": dict(zip(NAMES, (sd.std(0, ddof=1) / sd.mean(0)).tolist())),
           "fit_z_sd": dict(zip(NAMES, (err / sd).std(0, ddof=1).tolist())),
           "fit_inside_95": dict(zip(NAMES, np.sum([r["inside_95"] for r in rows], 0).tolist())),
           "exact_scatter_over_sd": dict(zip(NAMES, (ex.std(0, ddof=1) / exsd.mean(0)).tolist())),
           "fit_sd_over_exact_sd": dict(zip(NAMES, (sd.mean(0) / exsd.mean(0)).tolist())),
           "fit_scatter_over_exact_scatter": dict(zip(NAMES, (med.std(0, ddof=1)
                                                              / ex.std(0, ddof=1)).tolist())),
           "slope_fit_on_exact": dict(zip(NAMES, slope.tolist())),
           "excess_sd_over_exact_sd": dict(zip(NAMES, (excess / exsd.mean(0)).tolist())),
           "seed1_z": dict(zip(NAMES, z1.tolist())), "seed1_exact_z": dict(zip(NAMES, zx1.tolist())),
           "seed1_p_fit_given_exact": dict(zip(NAMES, p_cond.tolist()))}
    # chi-square band of a scatter/sd ratio from n replicas at level 0.01
    out["ratio_band_99"] = [float(np.sqrt(chi2.ppf(0.005, n - 1) / (n - 1))),
                            float(np.sqrt(chi2.isf(0.005, n - 1) / (n - 1)))]
    return out


def tail(readme):
    """Tail probabilities of seed 1's exact z and the misses they imply."""
    zx = abs(readme["runs"][0]["exact_z"][1])
    p = float(2 * norm.sf(zx))
    n = readme["all"]["n"]
    return {"seed1_exact_damping_abs_z": zx, "p_abs_z_at_least": p,
            "expected_seeds_beyond_of_n": p * n, "n": n,
            "expected_misses_95_of_n": 0.05 * n,
            "misses_95_99_band": [int(n - binom.isf(0.005, n, 0.95)),
                                  int(n - binom.ppf(0.005, n, 0.95))],
            "fit_misses_95": {k: n - v for k, v in readme["all"]["inside_95"].items()},
            "exact_misses_95": {k: n - v for k, v in readme["all"]["exact_inside_95"].items()}}


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--n", type=int, default=60)
    ap.add_argument("--readme", default="validation/results/cal/readme.json")
    ap.add_argument("--out", default="validation/results/cal/readme_replicas.json")
    args = ap.parse_args()
    with open(args.readme) as fh:
        readme = json.load(fh)
    sim = simulate_random_cal(truth=TRUTH, duration=3600, fs=5, seed=1)
    if args.n == 0:
        print(json.dumps(information(sim), indent=1))
        return
    rng = np.random.default_rng(20261128)
    t0 = time.process_time()
    rows = [one(sim, rng) for _ in range(args.n)]
    out = {"command": f"python validation/studies/cal_readme_replicas.py --n {args.n}",
           "cpu_s_per_run": (time.process_time() - t0) / args.n,
           "replicas": summary(rows, readme["runs"][0]), "tail": tail(readme),
           "information": information(sim), "runs": rows}
    study_results.write(args.out, out)
    print(json.dumps(study_results.summary_of(out), indent=1))


if __name__ == "__main__":
    main()
