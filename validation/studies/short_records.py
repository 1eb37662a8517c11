"""Short records: where the angles' intervals come out too narrow, and what
it is not (the table of ``docs/validation/errors_in_variables.md``, "Short records", and
of :mod:`bayescal.core.checks.record_length`).

Each variant fits the same 40 seeded pairs of ``validation/studies/eiv_coverage.py``
(10 Hz, coherence 0.9, reference noise-free, self-noise white in counts,
gains off their metadata by up to 3 % and fitted, ``--ref-noise quiet``) by
MCMC as ``bayescal fit`` does, and reports the z sd and the 90 % coverage per
parameter kind, with the periods of the band's lower edge in the record used.

    python validation/studies/short_records.py --out validation/results/eiv/short_records.json     # about 15 min

Variants: the record (900, 1800, 3600 s) and band (0.02-1, 0.05-1 Hz);
at 900 s over 0.02-1 Hz also 1024-sample segments, the Gaussian likelihood
(no per-band misfit term), the SUT's noise covariance held diagonal (its
cross-channel terms dropped; the misfit inflation is still the one computed
from the full covariance), and a diffuse ground field.
"""
from __future__ import annotations

import argparse
import json
import os
import sys
import time

import numpy as np

import eiv_coverage as ec                      # the sibling study, run as a script
import study_results                          # the sibling module

#: name -> (duration s, calibrate keywords, simulate_pair keywords, diagonal noise)
VARIANTS = {
    "900 s, 0.02-1 Hz": (900.0, {}, {}, False),
    "900 s, 0.02-1 Hz, 1024-sample segments": (900.0, {"nperseg": 1024}, {}, False),
    "900 s, 0.02-1 Hz, Gaussian likelihood": (900.0, {"misfit_shape": float("inf")}, {}, False),
    "900 s, 0.02-1 Hz, noise covariance diagonal": (900.0, {}, {}, True),
    "900 s, 0.02-1 Hz, diffuse ground (3)": (900.0, {}, {"diffuse": 3.0}, False),
    "1800 s, 0.02-1 Hz": (1800.0, {}, {}, False),
    "3600 s, 0.02-1 Hz": (3600.0, {}, {}, False),
    "900 s, 0.05-1 Hz": (900.0, {"band": (0.05, 1.0)}, {}, False),
}


def _diagonal_noise():
    """Hold the base model's SUT noise covariance diagonal (a study switch:
    its off-diagonal terms are what the SUT channels' noise shares); the
    inflation factors stay those estimated with the full covariance."""
    from bayescal.core.model import likelihood
    est = likelihood.Model.estimate_noise

    def estimate_noise(self, theta0):
        noise = est(self, theta0)
        sigma = noise.sigma * np.eye(noise.sigma.shape[-1])[None]
        inv = np.linalg.inv(sigma) / noise.inflation[:, None, None]
        self.noise = type(noise)(A=inv, B=noise.B, sigma=sigma, inflation=noise.inflation,
                                 scale0=noise.scale0, weight=noise.weight)
        return self.noise
    likelihood.Model.estimate_noise = estimate_noise
    return lambda: setattr(likelihood.Model, "estimate_noise", est)


def run_variant(duration, cal_kw, sim_kw, diagonal, seeds):
    cal, sim = ec.calibrate, ec.simulate_pair
    ec.calibrate = lambda *a, **k: cal(*a, **dict(k, **cal_kw))
    ec.simulate_pair = lambda *a, **k: sim(*a, **dict(k, **sim_kw))
    undo = _diagonal_noise() if diagonal else (lambda: None)
    try:
        rows = [ec.run_pair(s, 0.0, 0.9, "gain", "quiet", duration=duration) for s in seeds]
    finally:
        ec.calibrate, ec.simulate_pair = cal, sim
        undo()
    return rows


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--n", type=int, default=40)
    ap.add_argument("--seed0", type=int, default=800)
    ap.add_argument("--variants", nargs="+", default=list(VARIANTS))
    ap.add_argument("--out", default="validation/results/eiv/short_records.json")
    args = ap.parse_args(argv)
    out, t0 = {}, time.time()
    for name in args.variants:
        rows = run_variant(*VARIANTS[name], range(args.seed0, args.seed0 + args.n))
        kinds = {r["kind"]: r for r in ec.summarise(rows)}
        out[name] = {"summary": kinds, "rows": rows}
        line = ", ".join(f"{k} z sd {v['z_sd']:.2f} in90 {v['in90']}/{v['n']} {v['band90']}"
                         for k, v in kinds.items())
        print(f"{name}: {line} ({time.time() - t0:.0f} s)", flush=True)
    study_results.write(args.out, {"variants": out, "seconds": time.time() - t0, "n": args.n,
                                   "seed0": args.seed0})


if __name__ == "__main__":
    main()
