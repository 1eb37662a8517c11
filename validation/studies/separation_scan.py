"""Does the separation check (:mod:`bayescal.core.checks.separation`) tell the
regime where the reference's self-noise cannot be told from the SUT's gains?

48 seeded pairs (seeds 700-707; 1 h at 10 Hz, band 0.02-1 Hz, pair
coherence 0.99, metadata gains off by up to 3 %, as
``validation/studies/eiv_coverage.py``): self-noise white in counts (mode
``estimate``'s model) or shaped like the ground motion (not identifiable by
a pair), reference/SUT noise-power ratio 0, 1, 10, each fitted with the
default (``--ref-noise estimate``). Per pair: the largest gain sd ratio
(estimate over quiet, the check's statistic) and the mean standardised
gain error. About 6 minutes.

    python validation/studies/separation_scan.py [--out validation/results/eiv/separation_scan.json]
"""
from __future__ import annotations

import argparse
import json
import os
import sys

import numpy as np

from bayescal.core.checks.separation import WIDE_RATIO
from bayescal.simulate.harness import NOMINAL, coherences, draw_truth
from bayescal.pair.workflow import calibrate  # noqa: E402
from bayescal.simulate import simulate_pair  # noqa: E402
from bayescal.simulate.coverage import coverage_checks  # noqa: E402


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", default="validation/results/eiv/separation_scan.json")
    a = ap.parse_args(argv)
    rows = []
    for counts in (False, True):
        for ratio in (0.0, 1.0, 10.0):
            for seed in range(700, 708):
                azs, dips, resp = draw_truth(seed, "gain")
                cu, cr = coherences(0.99, ratio)
                sim = simulate_pair(duration=3600, fs=10, seed=seed, coherence=cu,
                                    ref_coherence=cr, sut_azimuth=azs, sut_dip=dips,
                                    sut_response=resp, nominal_response=NOMINAL,
                                    noise_in_counts=counts)
                post = calibrate(sut=sim.sut, sut_xml=sim.sut_inventory, ref=sim.ref, ref_xml=sim.ref_inventory,
                                 band=(0.02, 1.0), fit_response="gain", seed=seed,
                                 progress=False, min_ess=300, n_tau=20)
                zg = [v[1] for k, v in coverage_checks(post, azs, dips, resp).items()
                      if k.endswith(":gain")]
                sep = post.meta.reference_noise["separation"]
                rows.append({"noise": "counts" if counts else "signal", "ratio": ratio,
                             "seed": seed, "sd_ratio": max(sep["gain_sd_ratio"].values()),
                             "flagged": "note" in sep, "gain_z_mean": float(np.mean(zg))})
                print(rows[-1], flush=True)
    for noise in ("signal", "counts"):
        for ratio in (0.0, 1.0, 10.0):
            sel = [r for r in rows if r["noise"] == noise and r["ratio"] == ratio]
            r = np.array([x["sd_ratio"] for x in sel])
            print(f"{noise:6s} ratio {ratio:4g}: sd ratio {r.min():.2f}-{r.max():.2f}, flagged "
                  f"(> {WIDE_RATIO:g}) {sum(x['flagged'] for x in sel)}/{len(sel)}, gain z mean "
                  f"{np.mean([x['gain_z_mean'] for x in sel]):+.2f}")
    os.makedirs(os.path.dirname(a.out), exist_ok=True)
    with open(a.out, "w") as fh:
        json.dump({"command": "python validation/studies/separation_scan.py", "threshold": WIDE_RATIO,
                   "rows": rows}, fh, indent=1)


if __name__ == "__main__":
    main()
