"""CPU cost of the sampling alone, this tree against another tree, in one run.

Each case builds its posterior the way the command does and times only the
call of the sampler (``sample``: CPU seconds, ``time.process_time``), in a
fresh subprocess per tree and repeat, the trees alternated within each
repeat; medians over ``--repeats``. The import of emcee is timed apart
(CPU seconds of ``import emcee`` after ObsPy and the rest of bayescal are
loaded): it is paid once per command that samples.

Cases:

* ``orientation``: ``bayescal fit``'s default (gains free, the reference's
  noise estimated) on benchmarks/bench_process.py's 2-hour 20-Hz 3+3 pair;
* ``orientation_quiet``: the same with ``--ref-noise quiet``;
* ``joint``: the same pair with ``--fit-response all``;
* ``huddle``: ObsPy's huddle pair, gain fit in 0.1-2 Hz
  (``../shared/data/real/obspy_relcal``; skipped without it);
* ``coil``: ``bayescal cal --fit lp`` on a 3-hour 20-Hz random coil run
  (emcee's DE moves).

    python benchmarks/bench_sampling.py --before /path/to/older/tree [--repeats 5]
                                        [--out reports/benchmarks/sampling.json]
"""
from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
HUDDLE = ROOT.parent / "shared" / "data" / "real" / "obspy_relcal"
CASES = ("orientation", "orientation_quiet", "joint", "huddle", "coil")

WORKER = r"""
import json, sys, time
tree, case, folder = sys.argv[1:4]
sys.path.insert(0, tree)
sys.path.insert(0, tree + "/examples")
import numpy as np
import obspy
import bayescal.pair.workflow
t0 = time.process_time()
import emcee
t_import = time.process_time() - t0
import bayescal.coil, bayescal.criticism.diagnose
try:
    import bayescal.core.sampling.mcmc as home
except ImportError:
    import bayescal.core.fit.run as home
original = home.sample
record = []

def timed(*args, **kw):
    t = time.process_time()
    chain = original(*args, **kw)
    record.append({"cpu_s": time.process_time() - t, "n_steps": int(chain.n_steps),
                   "tau_max": float(np.max(chain.tau)), "converged": bool(chain.converged)})
    return chain

for mod in list(sys.modules.values()):
    if getattr(mod, "sample", None) is original:
        mod.sample = timed
import inspect
from bayescal.pair.workflow import calibrate_files as _cf
if "sut_files" in inspect.signature(_cf).parameters:    # positional, SUT first (older trees)
    calibrate_files = _cf
else:                                                   # keywords (this tree)
    def calibrate_files(sut, sut_xml, ref, ref_xml, **kw):
        return _cf(ref=ref, ref_xml=ref_xml, sut=sut, sut_xml=sut_xml, **kw)
if case.startswith("orientation") or case == "joint":
    p = json.load(open(folder + "/paths.json"))
    kw = {"orientation": {}, "orientation_quiet": {"ref_noise": "quiet"},
          "joint": {"fit_response": "all"}}[case]
    calibrate_files(p["sut.mseed"], p["sut.xml"], p["ref.mseed"], p["ref.xml"], progress=False,
                    **kw)
elif case == "huddle":
    calibrate_files(folder + "/huddle/sut.mseed", folder + "/huddle/sut.xml",
                    folder + "/huddle/ref.mseed", folder + "/huddle/ref.xml", band=(0.1, 2.0),
                    progress=False)
else:
    from bayescal import coil
    from bayescal.coil.random import fit_random
    from bayescal.simulate.cal import simulate_random_cal
    sim = simulate_random_cal(truth=(122.0, 0.69, 1510.0), duration=3 * 3600.0, fs=20.0, seed=11)
    fit_random(coil.read_run("U", sim.runs["cal"], sim.inventory, "BC0", "sim"), 1e-9,
               fit="lp")
print(json.dumps({"import_emcee_s": t_import, "calls": record}))
"""


def prepare(folder):
    """The 2-hour pair of bench_process.py and, when present, the huddle inputs."""
    sys.path.insert(0, str(ROOT))
    sys.path.insert(0, str(ROOT / "benchmarks"))
    from bench_process import DEMO_TRUTH

    from bayescal.simulate.pair import simulate_pair

    paths = simulate_pair(**DEMO_TRUTH).write(os.path.join(folder, "sim"))
    Path(folder, "paths.json").write_text(json.dumps(paths))
    if HUDDLE.is_dir():
        sys.path.insert(0, str(ROOT / "examples"))
        from real_huddle import write_inputs
        ref_xml, sut_xml = write_inputs(HUDDLE, os.path.join(folder, "huddle"))
        for name, target in (("sut.mseed", HUDDLE / "ref_unknown"), ("ref.mseed",
                             HUDDLE / "ref_STS2"), ("sut.xml", sut_xml), ("ref.xml", ref_xml)):
            os.symlink(os.path.abspath(target), os.path.join(folder, "huddle", name))


def one(tree, case, folder):
    env = dict(os.environ, OMP_NUM_THREADS="1")
    proc = subprocess.run([sys.executable, "-c", WORKER, str(tree), case, folder],
                          capture_output=True, text=True, env=env, cwd=folder)
    if proc.returncode:
        raise RuntimeError(f"{tree} {case}: {proc.stderr[-2000:]}")
    out = json.loads(proc.stdout.strip().splitlines()[-1])
    out["cpu_s"] = sum(c["cpu_s"] for c in out["calls"])
    return out


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--before", required=True, help="another source tree (e.g. a git worktree "
                                                    "of an older commit)")
    ap.add_argument("--repeats", type=int, default=5)
    ap.add_argument("--cases", nargs="+", default=list(CASES), choices=CASES)
    ap.add_argument("--out", default=str(ROOT / "reports" / "benchmarks" / "sampling.json"))
    args = ap.parse_args(argv)
    trees = {"after": ROOT, "before": Path(args.before).resolve()}
    cases = [c for c in args.cases if c != "huddle" or HUDDLE.is_dir()]
    runs = {(t, c): [] for t in trees for c in cases}
    with tempfile.TemporaryDirectory() as folder:
        prepare(folder)
        for k in range(args.repeats):
            for c in cases:
                for t, tree in trees.items():
                    runs[t, c].append(one(tree, c, folder))
                    print(f"repeat {k} {c:18s} {t:6s} sampling {runs[t, c][-1]['cpu_s']:.3f} s "
                          f"CPU", file=sys.stderr)
    result = {"repeats": args.repeats, "before": str(trees["before"]), "cases": {}}
    for c in cases:
        row = {}
        for t in trees:
            r = runs[t, c]
            row[t] = {"sampling_cpu_s": statistics.median(x["cpu_s"] for x in r),
                      "n_steps": [x["n_steps"] for x in r[0]["calls"]],
                      "tau_max": [round(x["tau_max"], 2) for x in r[0]["calls"]],
                      "converged": all(x["converged"] for y in r for x in y["calls"])}
        row["ratio_after_before"] = row["after"]["sampling_cpu_s"] / row["before"]["sampling_cpu_s"]
        result["cases"][c] = row
    result["import_emcee_cpu_s"] = statistics.median(
        x["import_emcee_s"] for c in cases for x in runs["after", c])
    os.makedirs(os.path.dirname(args.out), exist_ok=True)
    Path(args.out).write_text(json.dumps(result, indent=1) + "\n")
    for c, row in result["cases"].items():
        print(f"{c:18s} before {row['before']['sampling_cpu_s']:.3f} s  after "
              f"{row['after']['sampling_cpu_s']:.3f} s  ratio {row['ratio_after_before']:.3f}")
    print(f"import emcee: {result['import_emcee_cpu_s']:.3f} s CPU")


if __name__ == "__main__":
    main()
