"""Sine runs of the simulation-based calibration (``cal_coverage.py``'s
``sbc_run``, the same seeds and settings) fitted with the code as it is:
per run its frequency, self-noise colour, input noise, the z of the
response's amplitude and phase and the amplitude's relative error.

Runs 9 and 75 are the 1/f runs with sines near 1.4 Hz on which a fit
whose quadrature column was the Hilbert transform of the cut sine leant on
the cut's tails (docs/validation/coil.md); runs 0 and 1 are the first white
and the first 1/f run.

    python validation/studies/cal_sine_runs.py --runs 0 1 9 75
"""
from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
import study_results  # noqa: E402
from cal_coverage import sbc_run  # noqa: E402


def one(i, walkers, ess):
    row = sbc_run("sine", i, walkers, ess)
    out = {"i": i, **row["config"], "converged": row["converged"]}
    for name, e in row["parameters"].items():
        out[name] = {"z": (e["median"] - e["truth"]) / e["sd"], "median": e["median"],
                     "truth": e["truth"], "in95": e["in95"]}
    amp = row["parameters"]["response_amplitude"]
    out["amplitude_rel_error"] = amp["median"] / amp["truth"] - 1
    return out


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--runs", type=int, nargs="+", default=[0, 1, 9, 75])
    ap.add_argument("--walkers", type=int, default=16)
    ap.add_argument("--ess", type=int, default=200)
    ap.add_argument("--out", default="validation/results/cal/sine_runs.json")
    args = ap.parse_args()
    rows = {str(i): one(i, args.walkers, args.ess) for i in args.runs}
    out = {"command": "python validation/studies/cal_sine_runs.py --runs "
                      + " ".join(map(str, args.runs)),
           "sampler": {"n_walkers": args.walkers, "min_ess": args.ess}, "by_run": rows}
    study_results.write(args.out, out)
    print(json.dumps(out, indent=1))


if __name__ == "__main__":
    main()
