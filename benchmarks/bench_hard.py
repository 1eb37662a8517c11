"""Hard posteriors, this tree against another in one run: steps, tau,
acceptance, CPU time and the estimates of the commands a user runs where the
posterior is hard to sample or easy to misread.

Cases (each a fresh ``python -m bayescal`` subprocess, CPU = its user +
system time; the trees alternated within each repeat, medians over
``--repeats``):

* ``cowi_10min_HH``: ten minutes of ASL's COWI pair (band 1/8-1/3 Hz, the
  defaults: gains free, the reference's noise estimated), windows starting
  at 02, 03, 06, 09 and 12 h (needs ``../shared/data``);
* ``long_period``: a 360-s sensor seen from above its corner, 2 hours at
  20 Hz, ``--fit-response all``, band chosen from the data;
* ``coil_hf``: a random coil run at 200 Hz (1 hour) of a 120-s sensor,
  ``bayescal cal --fit all`` (the band reaches below the corner);
* ``coil_hf_20min``: the same for 20 minutes with the truth at 123 s and
  0.688: the band starts 6 times above the corner, so the run fixes
  damping/period and not period or damping;
* ``one_channel``: a vertical-only pair (one reference channel), gain fit.

    python benchmarks/bench_hard.py --before /path/to/older/tree [--repeats 3]
                                    [--out reports/benchmarks/hard.json]
"""
from __future__ import annotations

import argparse
import json
import os
import resource
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
COWI = ROOT.parent / "shared" / "data" / "real" / "asl_cowi_azimuth"
WINDOWS = ("02", "03", "06", "09", "12")


def prepare(folder):
    """Write the simulated inputs; returns {case: (argv, result file)}."""
    sys.path.insert(0, str(ROOT))
    from bayescal.simulate.cal import HF_NOMINAL, simulate_random_cal
    from bayescal.simulate.pair import simulate_pair

    cases = {}
    lp = simulate_pair(duration=7200, fs=20, seed=1, sut_response=((360.0, 0.707, 750.0),) * 3,
                       nominal_response=(360.0, 0.707, 750.0)).write(os.path.join(folder, "lp"))
    pair = ["--ref", lp["ref.mseed"], "--ref-xml", lp["ref.xml"], "--sut", lp["sut.mseed"],
            "--sut-xml", lp["sut.xml"]]
    cases["long_period"] = (["fit", *pair, "--fit-response", "all"], "result.json")
    cases["one_channel"] = (["fit", *pair, "--sut-id", "XX.SIM.10.BHZ", "--ref-id",
                             "XX.SIM.00.BHZ", "--band", "0.05", "2"], "result.json")
    cal = simulate_random_cal(truth=(120.0, 0.707, 1500.0), nominal=(120.0, 0.707, 1500.0),
                              hf_true=HF_NOMINAL, hf_nominal=HF_NOMINAL, duration=3600.0,
                              fs=200.0, seed=3).write(os.path.join(folder, "cal"))
    cases["coil_hf"] = (["cal", "--cal", cal["cal"], "--sut-xml", cal["xml"], "--coil-constant",
                         "1e-9", "--input-channel", "BC0", "--output-channel", "HHZ", "--fit",
                         "all"], "cal.json")
    short = simulate_random_cal(truth=(123.0, 0.688, 1510.0), nominal=(120.0, 0.707, 1500.0),
                                hf_true=HF_NOMINAL, hf_nominal=HF_NOMINAL, duration=1200.0,
                                fs=200.0, seed=3).write(os.path.join(folder, "cal_short"))
    cases["coil_hf_20min"] = (["cal", "--cal", short["cal"], "--sut-xml", short["xml"],
                               "--coil-constant", "1e-9", "--input-channel", "BC0",
                               "--output-channel", "HHZ", "--fit", "all"], "cal.json")
    if COWI.is_dir():
        for h in WINDOWS:
            cases[f"cowi_10min_{h}"] = (
                ["fit", "--ref", str(COWI / "DT000110.LH1"), str(COWI / "DT000110.LH2"),
                 "--ref-xml", "flat", "--sut", str(COWI / "C100823215422_COWI.LHx"),
                 "--sut-xml", "flat", "--band", "0.125", "0.3333333", "--start",
                 f"2010-08-24T{h}:00:00", "--end", f"2010-08-24T{h}:10:00"], "result.json")
    return cases


def run(tree, argv, result, folder):
    out = tempfile.mkdtemp(dir=folder)
    env = dict(os.environ, PYTHONPATH=str(tree), OMP_NUM_THREADS="1")
    r0 = resource.getrusage(resource.RUSAGE_CHILDREN)
    t0 = time.perf_counter()
    proc = subprocess.run([sys.executable, "-m", "bayescal", *argv, "--out", out, "--quiet",
                           "--no-report"] if argv[0] == "fit" else
                          [sys.executable, "-m", "bayescal", *argv, "--out", out, "--quiet"],
                          env=env, capture_output=True, text=True, cwd=folder)
    wall = time.perf_counter() - t0
    r1 = resource.getrusage(resource.RUSAGE_CHILDREN)
    cpu = (r1.ru_utime - r0.ru_utime) + (r1.ru_stime - r0.ru_stime)
    if proc.returncode not in (0, 3):
        return {"error": proc.stderr.strip().splitlines()[-1:], "cpu_s": cpu, "wall_s": wall}
    res = json.loads(Path(out, result).read_text())
    c = res["convergence"]
    row = {"cpu_s": cpu, "wall_s": wall, "exit": proc.returncode, "n_steps": c["n_steps"],
           "tau_max": round(c["tau_max"], 2), "acceptance": round(c["acceptance"], 3),
           "converged": c["converged"]}
    if "channels" in res:
        row["estimates"] = {cid: {k: [round(e[k]["median"], 3)] + [round(v, 3) for v in
                                                                   e[k]["ci95"]]
                                  for k in ("azimuth_deg",) if "ci95" in e.get(k, {})}
                            | {k: [round(v["median"], 4)] + [round(x, 4) for x in v["ci95"]]
                               for k, v in e.get("response", {}).items() if "ci95" in v}
                            for cid, e in res["channels"].items()}
    else:
        row["estimates"] = {k: [round(v["median"], 6)] + [round(x, 6) for x in v["ci95"]]
                            + (["set by the prior"] if v.get("set_by_prior") else [])
                            for k, v in res["parameters"].items() if isinstance(v, dict)}
    return row


def _commit(tree):
    """The commit a tree is at (with ``+`` when its files differ from it), or None."""
    try:
        head = subprocess.run(["git", "-C", str(tree), "rev-parse", "--short", "HEAD"],
                              capture_output=True, text=True, check=True).stdout.strip()
        dirty = subprocess.run(["git", "-C", str(tree), "status", "--porcelain", "--",
                                "bayescal"], capture_output=True, text=True).stdout.strip()
    except (OSError, subprocess.CalledProcessError):
        return None
    return head + ("+" if dirty else "")


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--before", required=True, help="another source tree")
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--out", default=str(ROOT / "reports" / "benchmarks" / "hard.json"))
    ap.add_argument("--cases", nargs="+", help="only these cases (the others kept from --out)")
    a = ap.parse_args(argv)
    trees = {"after": ROOT, "before": Path(a.before).resolve()}
    with tempfile.TemporaryDirectory() as folder:
        cases = prepare(folder)
        if a.cases:
            cases = {c: v for c, v in cases.items() if c in a.cases}
        rows = {(t, c): [] for t in trees for c in cases}
        for k in range(a.repeats):
            for c, (argv_, result) in cases.items():
                for t, tree in trees.items():
                    rows[t, c].append(run(tree, argv_, result, folder))
                    r = rows[t, c][-1]
                    print(f"repeat {k} {c:16s} {t:6s} cpu {r['cpu_s']:6.1f} s steps "
                          f"{r.get('n_steps')} tau {r.get('tau_max')}", file=sys.stderr,
                          flush=True)
    out = {"command": "python benchmarks/bench_hard.py " + " ".join(argv or sys.argv[1:]),
           "repeats": a.repeats, "before": str(trees["before"]), "cases": {}}
    for c in cases:
        entry = {}
        for t in trees:
            r = rows[t, c]
            ok = [x for x in r if "error" not in x]
            entry[t] = dict(ok[0] if ok else r[0], cpu_s=statistics.median(x["cpu_s"] for x in r),
                            wall_s=statistics.median(x["wall_s"] for x in r))
        entry["before_tree"] = {"path": str(trees["before"]), "commit": _commit(trees["before"])}
        entry["after_commit"] = _commit(ROOT)
        out["cases"][c] = entry
    os.makedirs(os.path.dirname(a.out), exist_ok=True)
    if a.cases and Path(a.out).is_file():
        old = json.loads(Path(a.out).read_text())
        for entry in old.get("cases", {}).values():     # each case keeps its own baseline
            entry.setdefault("before_tree", {"path": old.get("before"), "commit": None})
        out["cases"] = {**old.get("cases", {}), **out["cases"]}
        out["command"] = old.get("command", "") + " ; " + out["command"]
    Path(a.out).write_text(json.dumps(out, indent=1) + "\n")
    for c, e in out["cases"].items():
        print(f"{c:16s} before {e['before']['cpu_s']:6.1f} s ({e['before'].get('n_steps')} steps)"
              f"  after {e['after']['cpu_s']:6.1f} s ({e['after'].get('n_steps')} steps)")


if __name__ == "__main__":
    main()
