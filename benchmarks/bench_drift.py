"""Cost of the per-time-block likelihood that a clock drift needs.

One log-probability call (32 walkers, BLAS single-threaded as while
sampling) of the base model, of the base model with a constant timing
offset (band sums), and of the clock-drift model (one residual per band and
each of the 16 time blocks), on a 1-hour, 10 Hz, 3+3 simulated pair with a
20 ppm drift; plus the whole diagnosis with the final model sampled by
MCMC. The base model's call is the baseline measured in the same run;
medians over --repeats.

    python benchmarks/bench_drift.py [--repeats 5] [--out reports/benchmarks/drift.json]
"""
from __future__ import annotations

import argparse
import json
import os
import statistics
import time

import numpy as np
from threadpoolctl import threadpool_limits


def _per_call(model, theta, calls=200, walkers=32):
    rng = np.random.default_rng(0)
    batch = theta[None] + 1e-6 * rng.standard_normal((walkers, theta.size))
    model.log_prob(batch)
    t0 = time.perf_counter()
    for _ in range(calls):
        model.log_prob(batch)
    return (time.perf_counter() - t0) / calls


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeats", type=int, default=5)
    ap.add_argument("--out", default="reports/benchmarks/drift.json")
    args = ap.parse_args(argv)

    import bayescal
    from bayescal.criticism import effects
    from bayescal.criticism.diagnose import diagnose
    from bayescal.criticism.search import with_effects
    from bayescal.simulate.pair import simulate_pair

    sim = simulate_pair(duration=3600, fs=10, seed=4, coherence=0.98, sut_azimuth=(5, 95, 0),
                        clock_drift_ppm=20.0)
    post = bayescal.calibrate(sut=sim.sut, sut_xml=sim.sut_inventory, ref=sim.ref, ref_xml=sim.ref_inventory,
                              band=(0.05, 3.0), progress=False, diagnose=False)
    base, th = post.state.model, post.state.theta_ls
    base.estimate_noise(th)
    offset = with_effects(base, [effects.TimingOffset([0, 1, 2])])
    drift = with_effects(base, [effects.ClockDrift([0, 1, 2], post.state.spectra)])
    times = {"base": [], "timing_offset": [], "clock_drift": []}
    with threadpool_limits(1):
        for _ in range(args.repeats):
            times["base"].append(_per_call(base, th))
            times["timing_offset"].append(_per_call(offset, np.r_[th, 0.03]))
            times["clock_drift"].append(_per_call(drift, np.r_[th, 0.036, 20.0]))
    med = {k: statistics.median(v) * 1e3 for k, v in times.items()}
    t0 = time.perf_counter()
    d = diagnose(post.state, mcmc=True)
    whole = time.perf_counter() - t0
    out = {"log_prob_ms_median": med,
           "ratio_to_base": {k: v / med["base"] for k, v in med.items()},
           "diagnosis_with_mcmc_s": whole, "effects": d.names,
           "final_converged": bool(d.final.convergence.converged),
           "repeats": args.repeats, "walkers": 32}
    for k, v in med.items():
        print(f"{k:14s} {v:7.2f} ms per call  ({out['ratio_to_base'][k]:5.1f} x base)")
    print(f"whole diagnosis with MCMC: {whole:.1f} s; found {d.names}")
    os.makedirs(os.path.dirname(args.out) or ".", exist_ok=True)
    with open(args.out, "w") as fh:
        json.dump(out, fh, indent=1)


if __name__ == "__main__":
    main()
