"""What today's default fit costs against the orientation fit of an older
source tree, measured in the same run (the goal: the default no more than
1.5 times the orientation fit's 1.5 s on the 2-hour, 20-Hz pair).

The pair is ``benchmarks/bench_speed.py``'s (2 h at 20 Hz, 3+3 channels,
coherence 0.995, responses a few per cent off nominal), band 0.03-1 Hz.
Each timing is a fresh subprocess with one tree's ``bayescal`` on its path;
it times, in-process, the spectra and the fit (not the imports or the
simulation), as bench_speed.py does. Runs are alternated; medians of CPU
seconds over ``--repeats``.

* ``now default``: this tree's fit as ``bayescal fit`` configures it (gains
  free, ``--ref-noise estimate`` for 3+3, plug-in band weights), from the
  spectra of a fixed band: no band choice or coherence gate (the whole
  command is ``bench_process.py``'s);
* ``now orientation``: this tree, gains held, reference quiet;
* ``before orientation``: ``--before DIR`` (e.g. a checkout of 292a089^, the
  tree the issue was filed against), its default, which was orientation
  only with the reference quiet.

    python benchmarks/bench_default_cost.py --before /tmp/before [--repeats 5]
"""
from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]

CHILD = r"""
import inspect, json, sys, time
import numpy as np
from bayescal.core.fit.run import fit_spectra
from bayescal.core.spectra.welch import cross_spectra
try:
    from bayescal.io.align import align
except ImportError:          # older trees kept align in io.read
    from bayescal.io.read import align
from bayescal.simulate.pair import simulate_pair
RESP = ((28.5, 0.69, 761.0), (31.0, 0.72, 744.0), (30.0, 0.70, 752.0))
sim = simulate_pair(duration=7200, fs=20, seed=0, coherence=0.995, sut_response=RESP,
                    sut_azimuth=(3.0, 93.0, 10.0), sut_dip=(0.0, 0.3, -89.6))
s, r, fs = align(sim.sut, sim.sut_inventory, sim.ref, sim.ref_inventory)[:3]
kw = json.loads(sys.argv[1])
params = inspect.signature(fit_spectra).parameters
kw = {k: v for k, v in kw.items() if k in params}
c0 = time.process_time()
sp = cross_spectra(s.data, r.data, fs, s.response_fn(), r.response_fn(), (0.03, 1.0))
post = fit_spectra(sp, r.vectors, s.vectors, s.families(), seed=0, progress=False, **kw)
print(json.dumps({"cpu_s": time.process_time() - c0, "kw": kw,
                  "n_params": int(post.samples.shape[-1])}))
"""

CASES = {
    "now default": (None, {"free": "gain"}),
    "now orientation": (None, {"free": "none", "ref_noise": "quiet"}),
    "before orientation": ("before", {}),
}


def run(tree, kw):
    env = dict(os.environ, PYTHONPATH=str(tree), OMP_NUM_THREADS="1",
               OPENBLAS_NUM_THREADS="1", MKL_NUM_THREADS="1")
    out = subprocess.run([sys.executable, "-c", CHILD, json.dumps(kw)], env=env, cwd=str(tree),
                         capture_output=True, text=True)
    if out.returncode:
        raise SystemExit(f"timing in {tree} failed:\n{out.stderr[-2000:]}")
    return json.loads(out.stdout.strip().splitlines()[-1])


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--before", required=True, help="another source tree (its bayescal/ is used)")
    ap.add_argument("--repeats", type=int, default=5)
    ap.add_argument("--out", default="reports/benchmarks/default_cost.json")
    args = ap.parse_args(argv)
    trees = {None: ROOT, "before": Path(args.before).resolve()}
    runs = {name: [] for name in CASES}
    for k in range(args.repeats):
        for name, (tree, kw) in CASES.items():
            res = run(trees[tree], kw)
            runs[name].append(res)
            print(f"repeat {k + 1}: {name}: {res['cpu_s']:.2f} s CPU ({res['n_params']} parameters)",
                  file=sys.stderr, flush=True)
    med = {name: statistics.median(r["cpu_s"] for r in v) for name, v in runs.items()}
    head = subprocess.run(["git", "-C", str(trees["before"]), "rev-parse", "HEAD"],
                          capture_output=True, text=True).stdout.strip() or None
    out = {"command": "python benchmarks/bench_default_cost.py " + " ".join(argv or sys.argv[1:]),
           "before_tree": str(trees["before"]), "before_commit": head, "median_cpu_s": med,
           "ratio_default_to_before_orientation": med["now default"] / med["before orientation"],
           "ratio_default_to_now_orientation": med["now default"] / med["now orientation"],
           "runs": runs}
    for name, v in med.items():
        print(f"{name:20s} {v:6.2f} s CPU (median of {args.repeats})")
    print(f"default / before's orientation fit: {out['ratio_default_to_before_orientation']:.2f}x; "
          f"default / this tree's orientation fit: {out['ratio_default_to_now_orientation']:.2f}x")
    os.makedirs(os.path.dirname(args.out) or ".", exist_ok=True)
    with open(args.out, "w") as fh:
        json.dump(out, fh, indent=1)


if __name__ == "__main__":
    main()
