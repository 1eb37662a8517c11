"""Errors-in-variables study: gain and azimuth standardised errors of the
least-squares fit (Laplace intervals) for the reference-quiet model and the
errors-in-variables modes, over regimes of the reference's self-noise.

Each pair: 1 h at 10 Hz, band 0.02-1 Hz, SUT at a random azimuth, gains off
their metadata by up to 3 %, self-noise white in counts and the same on every
channel of a sensor (SUT 30 s, reference 120 s nominal responses), seeded.

    python benchmarks/eiv_study.py --n 12        # about 2 minutes per mode and regime

Writes reports/eiv/study.json and prints the table quoted in the README.
"""
from __future__ import annotations

import argparse
import json
import os
import time

import numpy as np

from bayescal.core.sampler import build_model, least_squares_fit
from bayescal.core.spectra import cross_spectra
from bayescal.io.align import align
from bayescal.simulate import simulate_pair

#: (label, SUT coherence, reference coherence): reference noise-free, as noisy
#: as the SUT, ten times noisier.
REGIMES = (("ref noise-free, coh 0.9", 0.9, 0.9999), ("equal noise, coh 0.9", 0.9, 0.9),
           ("ref 10x noisier, coh 0.99", 0.99, 0.908), ("ref 10x noisier, coh 0.999", 0.999, 0.99))


def one(mode, seed, coherence, ref_coherence):
    rng = np.random.default_rng(1000 + seed)
    gains = 750 * (1 + rng.uniform(-0.03, 0.03, 3))
    az = rng.uniform(0, 360)
    sim = simulate_pair(duration=3600, fs=10, seed=seed, coherence=coherence,
                        ref_coherence=ref_coherence, sut_azimuth=(az, az + 90, 0),
                        sut_dip=(0, 0, -90), noise_in_counts=True,
                        sut_response=tuple((30.0, 0.707, g) for g in gains))
    s, r, fs, _ = align(sim.sut, sim.sut_inventory, sim.ref, sim.ref_inventory)
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
    ap.add_argument("--out", default="reports/eiv/study.json")
    args = ap.parse_args()
    rows = []
    print(f"{'regime':28s} {'mode':9s} {'gain z mean':>11s} {'sd':>5s} {'in 90%':>7s} "
          f"{'az z mean':>9s} {'sd':>5s} {'in 90%':>7s}")
    for label, coh, refc in REGIMES:
        for mode in args.modes:
            t0 = time.time()
            zg, za = [], []
            for seed in range(args.n):
                g, a = one(mode, seed, coh, refc)
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
        json.dump({"command": "python benchmarks/eiv_study.py --n %d" % args.n, "rows": rows},
                  fh, indent=1)


if __name__ == "__main__":
    main()
