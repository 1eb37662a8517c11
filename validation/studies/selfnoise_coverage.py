"""Coverage of the self-noise intervals on simulations with known self-noise.

Three co-located verticals (:mod:`bayescal.simulate.selfnoise`: two STS-1 and
a Trillium 240, 20 Hz, 2 h like XPFO; noise white in acceleration, in
velocity and in counts; ambient-to-noise ratio 0 to 60 dB) go through
``cross_spectra`` and the estimator exactly as real data do.

Scenarios
  ideal:      the model holds. Intervals: Wishart (sampling only) and block bootstrap.
  misaligned: each sensor's axis is tilted by 1 mrad rms in each horizontal direction
              and sees independent horizontal ground motion (a model error).
              Intervals: Wishart without and with the 1 mrad allowance.

Coverage is counted at every 4th band of 16 per decade (a quarter decade apart,
so counted bands share no correlated bins), for each sensor and seed, with a
binomial 95 % range for the nominal 90 %. The three sensors' estimates in one
band come from one matrix and are correlated, so that range is a little too
narrow. Writes validation/results/selfnoise/coverage.json.

    python validation/studies/selfnoise_coverage.py [--seeds 60] [--n-boot 400]
"""
from __future__ import annotations

import argparse
import json
import time
from pathlib import Path

import numpy as np
from scipy import stats

from bayescal.core.selfnoise.sleeman import db
from bayescal.simulate.selfnoise import estimate_and_truth, simulate_colocated

ROOT = Path(__file__).resolve().parents[2]
THIN = 4
LEVEL = 0.9
SCENARIOS = {"ideal": (0.0, {"wishart": dict(method="wishart"),
                             "block": dict(method="block")}),
             "misaligned": (1e-3, {"wishart": dict(method="wishart"),
                                   "wishart+axis1mrad": dict(method="wishart",
                                                             axis_mismatch=1e-3)})}


def summarise(hits, widths, snrs, periods):
    """Coverage overall, per sensor, per period and per ambient/noise ratio."""
    h = np.array(hits)                                   # (seeds, 3, P)
    n, k = h.size, int(h.sum())
    lo, hi = stats.binom.ppf([0.025, 0.975], n, LEVEL) / n
    w = np.array(widths)
    by_snr = {}
    for a, b in ((-np.inf, 20), (20, 40), (40, np.inf)):
        m = (snrs >= a) & (snrs < b)
        if m.any():
            by_snr[f"{a:g}-{b:g} dB"] = {"rate": float(h[m].mean()), "n": int(m.sum())}
    return {"covered": k, "n": n, "rate": k / n, "binom95": [float(lo), float(hi)],
            "per_sensor": h.mean(axis=(0, 2)).tolist(), "per_period": h.mean(axis=(0, 1)).tolist(),
            "by_ambient_to_noise": by_snr,
            "median_width_db": float(np.nanmedian(np.where(np.isfinite(w), w, np.nan)))}


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--seeds", type=int, default=60)
    p.add_argument("--n-boot", type=int, default=400)
    p.add_argument("--out", default=str(ROOT / "validation" / "results" / "selfnoise" / "coverage.json"))
    a = p.parse_args(argv)
    t_start = time.time()
    summary = {"level": LEVEL, "n_seeds": a.seeds, "n_boot": a.n_boot,
               "simulation": "2 h at 20 Hz, STS-1/T240/STS-1, ground NLNM+10 dB"}
    for scenario, (mismatch, variants) in SCENARIOS.items():
        hits, widths, snrs, errs = {}, {}, [], []
        for s in range(a.seeds):
            seed = 1000 * (scenario == "misaligned") + s
            sim = simulate_colocated(7200.0, 20.0, seed=seed, axis_mismatch=mismatch)
            for name, kw in variants.items():
                est, true, C = estimate_and_truth(sim, band=(0.01, 8.0), n_boot=a.n_boot,
                                                  level=LEVEL, **kw)
                thin = np.arange(1, true.shape[1], THIN)
                t = true[:, thin]
                hits.setdefault(name, []).append((est.lo[:, thin] <= t) & (t <= est.hi[:, thin]))
                widths.setdefault(name, []).append(db(est.hi[:, thin]) - db(est.lo[:, thin]))
                if name == "wishart":
                    errs.append(db(est.psd[:, thin]) - db(t))
                    snrs.append(db(np.real(np.einsum("bii->ib", C))[:, thin] / t))
            print(f"\r{scenario}: seed {s + 1}/{a.seeds}", end="", flush=True)
        periods = 1 / est.freqs[thin]
        out = {"periods_s": np.round(periods, 3).tolist()}
        print(f"\n=== {scenario}: {a.seeds} seeds x 3 sensors x {periods.size} periods "
              f"({', '.join(f'{p:.3g}' for p in periods)} s)")
        for name in variants:
            r = summarise(hits[name], widths[name], np.array(snrs), periods)
            out[name] = r
            print(f"  {name:18s}: coverage {r['covered']}/{r['n']} = {r['rate']:.3f} "
                  f"(binomial 95 % range for 0.90: {r['binom95'][0]:.3f}-{r['binom95'][1]:.3f}); median width "
                  f"{r['median_width_db']:.2f} dB; per sensor "
                  + ", ".join(f"{v:.3f}" for v in r["per_sensor"]) + "; by ambient/noise "
                  + "; ".join(f"{k}: {v['rate']:.3f} (n={v['n']})"
                              for k, v in r["by_ambient_to_noise"].items()))
        e = np.array(errs)
        out["point_error_db"] = {"median": float(np.nanmedian(e)),
                                 "q90_abs": float(np.nanquantile(np.abs(e), 0.9)),
                                 "fraction_not_positive": float(np.isnan(e).mean())}
        print(f"  point estimate error: median {np.nanmedian(e):+.2f} dB, 90 % of |error| < "
              f"{np.nanquantile(np.abs(e), 0.9):.2f} dB; not positive: {np.isnan(e).mean():.3f}")
        summary[scenario] = out
    summary["seconds"] = round(time.time() - t_start, 1)
    Path(a.out).parent.mkdir(parents=True, exist_ok=True)
    Path(a.out).write_text(json.dumps(summary, indent=1))
    print(f"{summary['seconds']:.0f} s; wrote {a.out}")


if __name__ == "__main__":
    main()
