"""The coverage runs of ``tests/test_cal.py`` (its ``coverage_run``, seeds
0-179: 2 h at 4 Hz, truths drawn around the nominal), with the statistics
its three coverage tests assert and their power, stored.

Per parameter (period, damping, gain): the count of truths inside the 90 %
and 68 % intervals against ``interval_bounds``; ``sum z^2`` of ``z =
(median - truth) / sd`` against chi-square(N)'s ``1 - 0.001 / 3`` quantile
and its power against that parameter's intervals 1.3 times too narrow
(closed form, ``chi2.sf(bound / 1.3 ** 2, N)``); the sum of the squared
Mahalanobis distances against chi-square(3N)'s 0.999 quantile. The CPU
seconds per run are those of this process.

    python validation/studies/cal_suite_coverage.py
"""
from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

import numpy as np
from scipy.stats import chi2

sys.path.insert(0, str(Path(__file__).resolve().parents[2]))
sys.path.insert(0, str(Path(__file__).resolve().parent))
import study_results  # noqa: E402
from tests.test_cal import N_COVERAGE, coverage_run  # noqa: E402
from tests.tolerance import LEVEL, interval_bounds  # noqa: E402

NAMES = ("period_s", "damping", "gain")


def statistics(hits, m, z):
    """The tests' statistics of (N, 2, 3) hits, (N,) Mahalanobis distances
    and (N, 3) z."""
    n = len(m)
    each = chi2.isf(LEVEL / 3, n)
    joint = chi2.isf(LEVEL, 3 * n)
    lo, hi = interval_bounds(n)
    return {
        "n": n,
        "inside_90": dict(zip(NAMES, hits[:, 0].sum(0).tolist())),
        "inside_68": dict(zip(NAMES, hits[:, 1].sum(0).tolist())),
        "interval_bounds": {"lo90": lo, "hi68": hi},
        "sum_z2": dict(zip(NAMES, (z ** 2).sum(0).tolist())),
        "z_rms": dict(zip(NAMES, np.sqrt((z ** 2).mean(0)).tolist())),
        "z_mean": dict(zip(NAMES, z.mean(0).tolist())),
        "each_bound": float(each), "each_bound_z_rms": float(np.sqrt(each / n)),
        "each_power_1p3": float(chi2.sf(each / 1.3 ** 2, n)),
        "each_power_1p2": float(chi2.sf(each / 1.2 ** 2, n)),
        "mahalanobis_sum": float(m.sum()), "mahalanobis_bound": float(joint),
        "mahalanobis_power_1p2": float(chi2.sf(joint / 1.2 ** 2, 3 * n)),
        "mahalanobis_power_1p3": float(chi2.sf(joint / 1.3 ** 2, 3 * n)),
        "passes": bool(np.all((z ** 2).sum(0) <= each) and m.sum() <= joint
                       and hits[:, 0, 2].sum() >= lo and np.all(hits[:, 1].sum(0) <= hi)),
    }


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--n", type=int, default=N_COVERAGE)
    ap.add_argument("--out", default="validation/results/cal/suite_coverage.json")
    args = ap.parse_args()
    t0 = time.process_time()
    rows = [coverage_run(s) for s in range(args.n)]
    cpu = (time.process_time() - t0) / args.n
    hits, m, z = (np.array([r[k] for r in rows]) for k in range(3))
    out = {"command": "python validation/studies/cal_suite_coverage.py"
                      + (f" --n {args.n}" if args.n != N_COVERAGE else ""),
           "cpu_s_per_run": cpu, **statistics(hits, m, z),
           "runs": [{"seed": s, "z": zz.tolist(), "mahalanobis2": float(mm)}
                    for s, zz, mm in zip(range(args.n), z, m)]}
    study_results.write(args.out, out)
    print(json.dumps(study_results.summary_of(out), indent=1))


if __name__ == "__main__":
    main()
