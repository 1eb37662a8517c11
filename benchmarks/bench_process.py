"""Whole-process speed of ``bayescal`` as a user meets it.

Every command runs as a fresh subprocess (start-up included), all commands
alternated within each repeat, medians over ``--repeats`` (>= 5) runs:

* ``help``: ``bayescal --help``;
* ``fit``: ``bayescal fit --no-report`` (orientation, band chosen from the
  data) on a 2-hour 20-Hz 3+3 simulated pair (``bayescal.simulate.simulate_pair``
  with ``examples/demo.py``'s truth, written to miniSEED + StationXML);
* ``floor``: the same-run floor for it, a script that imports ObsPy, reads
  both files and computes all 36 Welch cross-spectra with scipy;
* ``huddle``: ``bayescal fit --fit-response gain --band 0.1 2 --no-report`` on
  ObsPy's huddle pair (``../shared/data/real/obspy_relcal``; skipped without it);
* ``obspy``: ObsPy's ``rel_calib_stack(st1, st2, 'STS2_simp.cal', 20, smooth=10)``
  on the same pair, the point estimate the huddle fit is compared with;
* ``import emcee``: the CPU of ``import emcee`` in a process that has already
  imported ObsPy and bayescal's fit path (emcee imports scipy.stats): the
  cost every sampling command pays once, measured in the same run. The goals
  are stated with it: fit <= 2 x floor + import, huddle <= obspy + import.

Wall and CPU (user + system) time are both kept; on a shared machine the CPU
time is the steadier of the two. ``--before DIR`` also times the bayescal commands of another source tree
(e.g. ``/work/main``) in the same run, as ``*_before``.

    python benchmarks/bench_process.py [--repeats 5] [--before /work/main]
                                       [--out reports/benchmarks/process.json]
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
HUDDLE = ROOT.parent / "shared" / "data" / "real" / "obspy_relcal"
DEMO_TRUTH = dict(duration=7200, fs=20, seed=2026, coherence=0.995, sut_azimuth=(3.0, 93.4, 25.0),
                  sut_dip=(0.0, 0.3, -89.6), nominal_response=(30.0, 0.707, 750.0),
                  sut_response=((28.5, 0.69, 761.0), (31.0, 0.72, 744.0), (30.0, 0.70, 752.0)))

FLOOR = """
import sys, itertools
import numpy as np
import obspy
from scipy.signal import csd
st = obspy.read(sys.argv[1]) + obspy.read(sys.argv[2])
x = [tr.data.astype(float) for tr in st]
fs = st[0].stats.sampling_rate
for a, b in itertools.product(range(len(x)), repeat=2):
    csd(x[a], x[b], fs=fs, nperseg=8192)
"""

IMPORT = """
import time
import obspy, bayescal.pair.workflow, bayescal.core.fit.run
t = time.process_time()
import emcee
print(time.process_time() - t)
"""

OBSPY = """
import sys
import obspy
from obspy.signal.calibration import rel_calib_stack
d = sys.argv[1]
rel_calib_stack(obspy.read(d + "/ref_STS2"), obspy.read(d + "/ref_unknown"),
                d + "/STS2_simp.cal", 20, smooth=10, save_data=False)
"""


def prepare(folder):
    """Write the simulated pair and, when the data exist, the huddle
    StationXML into ``folder``; returns {name: argv} of the commands."""
    sys.path.insert(0, str(ROOT))
    from bayescal.simulate.pair import simulate_pair

    p = simulate_pair(**DEMO_TRUTH).write(os.path.join(folder, "sim"))
    out = os.path.join(folder, "out")
    fit = ["fit", "--ref", p["ref.mseed"], "--ref-xml", p["ref.xml"], "--sut", p["sut.mseed"],
           "--sut-xml", p["sut.xml"], "--no-report", "--quiet", "--out"]
    cmds = {"help": (["-m", "bayescal", "--help"], True),
            "fit": (["-m", "bayescal"] + fit + [out + "_fit"], True),
            "floor": (["-c", FLOOR, p["sut.mseed"], p["ref.mseed"]], False)}
    if HUDDLE.is_dir():
        sys.path.insert(0, str(ROOT / "examples"))
        from real_huddle import write_inputs

        ref_xml, sut_xml = write_inputs(HUDDLE, os.path.join(folder, "huddle"))
        cmds["huddle"] = (["-m", "bayescal", "fit", "--ref", str(HUDDLE / "ref_STS2"),
                           "--ref-xml", ref_xml, "--sut", str(HUDDLE / "ref_unknown"),
                           "--sut-xml", sut_xml, "--fit-response", "gain", "--band", "0.1", "2",
                           "--no-report", "--quiet", "--out", out + "_huddle"], True)
        cmds["obspy"] = (["-c", OBSPY, str(HUDDLE)], False)
    return cmds


def timed(argv, pythonpath, cwd):
    """(wall, CPU) seconds of one subprocess; CPU = its user + system time,
    the steadier figure when other jobs share the cores. Run from ``cwd``
    (not a source tree: ``python -m`` would import the package found there)."""
    env = dict(os.environ, PYTHONPATH=str(pythonpath), OMP_NUM_THREADS="1")
    r0 = resource.getrusage(resource.RUSAGE_CHILDREN)
    t0 = time.perf_counter()
    subprocess.run([sys.executable] + argv, env=env, check=True, stdout=subprocess.DEVNULL,
                   cwd=cwd)
    wall = time.perf_counter() - t0
    r1 = resource.getrusage(resource.RUSAGE_CHILDREN)
    return wall, (r1.ru_utime - r0.ru_utime) + (r1.ru_stime - r0.ru_stime)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeats", type=int, default=5)
    ap.add_argument("--before", type=Path, help="another source tree to time in the same run")
    ap.add_argument("--out", default=str(ROOT / "reports" / "benchmarks" / "process.json"))
    a = ap.parse_args(argv)
    with tempfile.TemporaryDirectory() as tmp:
        cmds = prepare(tmp)
        runs = [(name, argv_, ROOT) for name, (argv_, _) in cmds.items()]
        if a.before:
            runs += [(f"{name}_before", argv_, a.before) for name, (argv_, ours) in cmds.items()
                     if ours]
        walls = {name: [] for name, _, _ in runs}
        cpus = {name: [] for name, _, _ in runs}
        imports = []
        for r in range(a.repeats):
            for name, argv_, path in runs:              # alternated within each repeat
                w, c = timed(argv_, path, tmp)
                walls[name].append(w)
                cpus[name].append(c)
            imports.append(float(subprocess.run(
                [sys.executable, "-c", IMPORT], env=dict(os.environ, PYTHONPATH=str(ROOT)),
                capture_output=True, text=True, check=True, cwd=tmp).stdout.strip()))
            print(f"repeat {r + 1}/{a.repeats} (wall/CPU s): " + ", ".join(
                f"{k} {walls[k][-1]:.2f}/{cpus[k][-1]:.2f}" for k in walls), flush=True)
    result = {"command": "python benchmarks/bench_process.py " + " ".join(argv or sys.argv[1:]),
              "machine": f"{os.cpu_count()} cores, shared", "repeats": a.repeats,
              "runs_wall_s": walls, "runs_cpu_s": cpus, "import_emcee_cpu_s": imports}
    emcee_s = statistics.median(imports)
    for kind, times in (("wall", walls), ("cpu", cpus)):
        med = {k: statistics.median(v) for k, v in times.items()}
        ratios = {"fit / floor": med["fit"] / med["floor"]}
        if "huddle" in med:
            ratios["huddle / obspy"] = med["huddle"] / med["obspy"]
        for k in ("fit", "huddle", "help"):
            if f"{k}_before" in med:
                ratios[f"{k}_before / {k}"] = med[f"{k}_before"] / med[k]
        med["import emcee"] = emcee_s
        goals = {"fit <= 2 x floor + import emcee": med["fit"] <= 2.0 * med["floor"] + emcee_s,
                 "help < 0.5 s": med["help"] < 0.5}
        if "huddle / obspy" in ratios:
            goals["huddle <= obspy + import emcee"] = med["huddle"] <= med["obspy"] + emcee_s
        result[kind] = {"median_s": med, "ratios": ratios, "goals_met": goals}
        print(f"--- {kind} time, medians")
        for k, v in list(med.items()) + list(ratios.items()):
            print(f"{k:24s} {v:6.2f}")
        print("goals:", goals)
    os.makedirs(os.path.dirname(a.out), exist_ok=True)
    with open(a.out, "w") as fh:
        json.dump(result, fh, indent=1)
    return 0


if __name__ == "__main__":
    sys.exit(main())
