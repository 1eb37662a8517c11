"""Same estimates from two source trees: one seeded pair fit in each, compared.

The pair is ``benchmarks/bench_process.py``'s 2-hour 20-Hz 3+3 simulated
pair (its ``DEMO_TRUTH``), fitted with seed 0, no criticism, in a fresh
subprocess per tree. Deterministic values (the least-squares point, the
reference's noise coefficients and inflation, the plug-in precision's sum,
the modes' log-posterior differences) are compared by their largest
difference, relative and, for the least-squares point, in units of each
parameter's posterior sd; the sampled medians in units of their Monte Carlo
error (the posterior sd over the square root of the smaller ESS).

    python validation/studies/same_estimates.py --before /work/main
        [--out validation/results/speed/same_estimates.json]
"""
from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[2]

FIT = """
import json, sys, warnings
import numpy as np
warnings.simplefilter("ignore")
from bayescal.pair.workflow import calibrate_files
d = sys.argv[1]
r = calibrate_files(ref=d + "/ref.mseed", ref_xml=d + "/ref.xml", sut=d + "/sut.mseed",
                    sut_xml=d + "/sut.xml", seed=0, progress=False, diagnose=False)
s, m = r.summary(), r.state.model
json.dump({"least_squares": s["meta"]["least_squares"],
           "noise_inflation": list(map(float, s["meta"]["noise_inflation"])),
           "noise_rho": np.asarray(m.noise.rho).tolist(),
           "noise_W_sum": float(np.sum(m.noise.W)),
           "modes": [[x["start"], x["log_posterior_difference"]]
                     for x in s["multimodal"]["modes"]],
           "channels": s["channels"], "ess_min": s["convergence"]["ess_min"]},
          open(sys.argv[2], "w"), default=float)
"""


def _fit(tree, folder, out):
    env = dict(os.environ, PYTHONPATH=str(tree), OMP_NUM_THREADS="1")
    subprocess.run([sys.executable, "-c", FIT, folder, out], env=env, check=True, cwd=folder)
    with open(out) as fh:
        return json.load(fh)


def _rel(a, b):
    a, b = np.asarray(a, float), np.asarray(b, float)
    return float(np.max(np.abs(a - b) / np.maximum(np.abs(a), 1e-300)))


def _medians(a, b):
    """{channel quantity: difference of medians in Monte Carlo errors}."""
    ess = min(a["ess_min"], b["ess_min"])
    out = {}
    for cid, ch in a["channels"].items():
        for name, e in list(ch.items()) + list(ch.get("response", {}).items()):
            if isinstance(e, dict) and e.get("median") is not None:
                e2 = b["channels"][cid].get(name) or b["channels"][cid]["response"][name]
                out[f"{cid} {name}"] = abs(e["median"] - e2["median"]) / (e["sd"] / np.sqrt(ess))
    return out


def compare(a, b):
    """The differences the module docstring lists, ``a`` the reference tree's."""
    names = list(a["least_squares"])
    la, lb = (np.array([x["least_squares"][n] for n in names]) for x in (a, b))
    return {"least_squares_max_abs": float(np.max(np.abs(la - lb))),
            "least_squares_max_rel": _rel(la, lb),
            "noise_inflation_max_rel": _rel(a["noise_inflation"], b["noise_inflation"]),
            "noise_rho_max_rel": _rel(a["noise_rho"], b["noise_rho"]),
            "noise_W_sum_rel": _rel(a["noise_W_sum"], b["noise_W_sum"]),
            "modes": {"before": a["modes"], "after": b["modes"]},
            "median_mc_errors_max": max(_medians(a, b).values())}


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--before", type=Path, required=True, help="the other source tree")
    ap.add_argument("--out", default=str(ROOT / "validation" / "results" / "speed"
                                         / "same_estimates.json"))
    a = ap.parse_args(argv)
    sys.path.insert(0, str(ROOT / "benchmarks"))
    sys.path.insert(0, str(ROOT))
    from bench_process import DEMO_TRUTH

    from bayescal.simulate.pair import simulate_pair
    with tempfile.TemporaryDirectory() as tmp:
        simulate_pair(**DEMO_TRUTH).write(tmp)
        before = _fit(a.before, tmp, os.path.join(tmp, "before.json"))
        after = _fit(ROOT, tmp, os.path.join(tmp, "after.json"))
    result = {"command": "python validation/studies/same_estimates.py "
                         + " ".join(argv or sys.argv[1:]), **compare(before, after)}
    os.makedirs(os.path.dirname(a.out), exist_ok=True)
    with open(a.out, "w") as fh:
        json.dump(result, fh, indent=1)
    print(json.dumps(result, indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(main())
