"""Whole-process speed of ``bayescal`` as a user meets it, in one command.

Every command runs as a fresh subprocess (start-up included), all commands
alternated within each repeat, medians over ``--repeats`` (default 7):

* ``help``: ``bayescal --help``;
* ``fit``: ``bayescal fit --no-report`` (orientation, band chosen from the
  data) on a 2-hour 20-Hz 3+3 simulated pair (``bayescal.simulate.simulate_pair``
  with ``examples/demo.py``'s truth, written to miniSEED + StationXML). Its
  SUT's periods are off the metadata's, so the model check fails and the
  criticism runs: its seconds are read from result.json
  (``criticism.seconds``) and ``fit_nodiag`` (the same with
  ``--no-diagnose``) times the fit without it;
* ``floor``: the same-run floor for it, a script that imports emcee (the
  sampler every fit runs) and ObsPy, reads both files and computes all 36
  Welch cross-spectra with scipy;
* ``huddle``: ``bayescal fit --fit-response gain --band 0.1 2 --no-report`` on
  ObsPy's huddle pair (``../shared/data/real/obspy_relcal``; skipped without
  it), criticism timed as for ``fit``;
* ``obspy``: ObsPy's ``rel_calib_stack(st1, st2, 'STS2_simp.cal', 20, smooth=10)``
  on the same pair with ``import emcee`` added, the baseline of ``huddle``;
* ``import emcee``: the CPU of ``import emcee`` in a process that has already
  imported ObsPy and bayescal's fit path (emcee imports scipy.stats): the
  cost every sampling command pays once, stated apart.

Each tree's package runs from a copy compiled to bytecode first, as an
installation is (pip compiles what it installs), so that no child spends
its start-up compiling bayescal's sources whatever
``PYTHONDONTWRITEBYTECODE`` says (the libraries run from their installed
bytecode either way).

Wall and CPU (user + system) time of each child are kept, and its peak
memory (``ru_maxrss``); on a shared machine the CPU time is the steadier of
the two, and the machine's load (``os.getloadavg``) is printed with every
repeat. Goals: fit <= 1.5 x floor, huddle <= obspy, help <= 0.3 s, peak
memory of the fit <= 226 MiB (without the criticism and with it).
``--before DIR`` also times the bayescal commands of another source tree
(e.g. ``/work/main``) in the same run, as ``*_before``.

    python benchmarks/bench_process.py [--repeats 7] [--before /work/main]
                                       [--out reports/benchmarks/process.json]

``--stages`` instead runs ``fit_nodiag``, ``huddle`` and the floor
``--repeats`` times each, each run a fresh process, and gives the medians
of their CPU seconds by stage (start-up and imports, read, spectra, least
squares, noise estimate, mode search, sampling, the criticism whole, the
result, writing; the floor's start-up and imports, read and spectra), with
the CPU of the fit's imports beyond the floor's (bayescal's parser and fit
path, imported after emcee, ObsPy and SciPy), in
``reports/benchmarks/process_stages.json``.
"""
from __future__ import annotations

import argparse
import compileall
import contextlib
import json
import os
import shutil
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
import emcee
import numpy as np
import obspy
from scipy.signal import csd
st = obspy.read(sys.argv[1]) + obspy.read(sys.argv[2])
x = [tr.data.astype(float) for tr in st]
fs = st[0].stats.sampling_rate
for a, b in itertools.product(range(len(x)), repeat=2):
    csd(x[a], x[b], fs=fs, nperseg=8192)
"""

FLOOR_STAGES = FLOOR.replace("st = obspy.read", """
import json, resource

def cpu():
    r = resource.getrusage(resource.RUSAGE_SELF)
    return r.ru_utime + r.ru_stime

spent = {"start-up and imports": cpu()}
st = obspy.read""", 1).replace("for a, b in", """spent["read"] = cpu() - spent["start-up and imports"]
for a, b in""", 1) + """
spent["total"] = cpu()
spent["spectra"] = spent["total"] - spent["read"] - spent["start-up and imports"]
print(json.dumps(spent))
"""

OWN_IMPORTS = """
import resource

def cpu():
    r = resource.getrusage(resource.RUSAGE_SELF)
    return r.ru_utime + r.ru_stime

import emcee, obspy, scipy.signal
t = cpu()
from bayescal.cli import build_parser
build_parser()
import bayescal.pair.workflow, bayescal.core.fit.run, bayescal.core.fit.modes
import bayescal.core.sampling.mcmc, bayescal.io.result, bayescal.io.stationxml
print(cpu() - t)
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
import emcee
import obspy
from obspy.signal.calibration import rel_calib_stack
d = sys.argv[1]
rel_calib_stack(obspy.read(d + "/ref_STS2"), obspy.read(d + "/ref_unknown"),
                d + "/STS2_simp.cal", 20, smooth=10, save_data=False)
"""

STAGES = """
import json, resource, sys

def cpu():
    r = resource.getrusage(resource.RUSAGE_SELF)
    return r.ru_utime + r.ru_stime

import bayescal.core.sampling.mcmc, bayescal.io.result, bayescal.core.model.likelihood as L
import bayescal.core.model.eiv as E, bayescal.core.fit.run as R
import bayescal.pair.workflow as W
spent, stack = {}, []

def timed(owner, attr, stage):
    f = getattr(owner, attr)
    def g(*a, **k):
        if "criticism" in stack:      # the criticism is timed whole
            return f(*a, **k)
        t = cpu()
        if stack:
            spent[stack[-1]] = spent.get(stack[-1], 0.0) + t - stack_t[-1]
        stack.append(stage); stack_t.append(t)
        try:
            return f(*a, **k)
        finally:
            t = cpu()
            spent[stage] = spent.get(stage, 0.0) + t - stack_t.pop()
            stack.pop()
            if stack:
                stack_t[-1] = t
    setattr(owner, attr, g)

stack_t = []
for owner, attr, stage in [(W, "read_waveforms", "read"), (W, "load_inventory", "read"),
                           (W, "prepare", "spectra"), (W, "fit", "fit, other"),
                           (R, "least_squares_fit", "least squares"),
                           (L.Model, "estimate_noise", "noise estimate"),
                           (E.EIVModel, "estimate_noise", "noise estimate"),
                           (R, "_modes", "mode search"),
                           (bayescal.core.sampling.mcmc, "sample", "sampling"),
                           (W, "criticise", "criticism"), (W, "choose", "result"),
                           (bayescal.io.result, "write_results", "writing")]:
    timed(owner, attr, stage)
orig_read = W.read_waveforms
def first(*a, **k):
    spent.setdefault("start-up and imports", cpu())
    return orig_read(*a, **k)
W.read_waveforms = first
from bayescal.cli import main
try:
    main(sys.argv[1:])
except SystemExit:
    pass
spent["total"] = cpu()
spent["rest"] = spent["total"] - sum(v for k, v in spent.items() if k != "total")
print(json.dumps(spent))
"""


def installed(tree, folder):
    """``folder`` holding a copy of ``tree``'s package compiled to bytecode
    (module docstring): the PYTHONPATH its commands run with."""
    dest = os.path.join(folder, "bayescal")
    shutil.copytree(os.path.join(tree, "bayescal"), dest,
                    ignore=shutil.ignore_patterns("__pycache__"))
    compileall.compile_dir(dest, quiet=1)
    return folder


def stages(cmds, cwd, path, repeats):
    """CPU seconds by stage, medians over ``repeats`` fresh processes each:
    ``fit_nodiag`` and ``huddle`` (:data:`STAGES`: the time inside a
    stage's calls, less the stages nested in them; the criticism whole;
    "start-up and imports" up to the first read, imports made later
    counted where they are made), the floor (:data:`FLOOR_STAGES`: its
    start-up and imports, reading, the 36 cross-spectra) and
    ``own_imports``, the fit's imports beyond the floor's
    (:data:`OWN_IMPORTS`: bayescal's parser and fit path after emcee,
    ObsPy and SciPy). Returns ``(medians, runs)``."""
    env = dict(os.environ, PYTHONPATH=str(path), OMP_NUM_THREADS="1")
    scripts = {name: [STAGES] + cmds[name][0][2:] for name in ("fit_nodiag", "huddle")
               if name in cmds}
    scripts["floor"] = [FLOOR_STAGES] + cmds["floor"][0][2:]
    scripts["own_imports"] = [OWN_IMPORTS]
    runs = {name: [] for name in scripts}
    for r in range(repeats):
        for name, (script, *args) in scripts.items():
            out = subprocess.run([sys.executable, "-c", script] + args, capture_output=True,
                                 text=True, check=True, cwd=cwd, env=env).stdout
            runs[name].append(json.loads(out.strip().splitlines()[-1]))
        print(f"stages, repeat {r + 1}/{repeats}, load {os.getloadavg()[0]:.1f}", flush=True)
    medians = {name: statistics.median(v) if not isinstance(v[0], dict) else
               {k: statistics.median(x.get(k, 0.0) for x in v) for k in dict.fromkeys(
                   k for x in v for k in x)} for name, v in runs.items()}
    for name, m in medians.items():
        print(name, m if not isinstance(m, dict) else {k: round(v, 3) for k, v in m.items()})
    return medians, runs


def prepare(folder):
    """Write the simulated pair and, when the data exist, the huddle
    StationXML into ``folder``; returns {name: (argv, ours, result folder)}
    of the commands (``ours``: a bayescal command, also timed in ``--before``)."""
    sys.path.insert(0, str(ROOT))
    from bayescal.simulate.pair import simulate_pair

    p = simulate_pair(**DEMO_TRUTH).write(os.path.join(folder, "sim"))
    out = os.path.join(folder, "out")
    fit = ["-m", "bayescal", "fit", "--ref", p["ref.mseed"], "--ref-xml", p["ref.xml"], "--sut",
           p["sut.mseed"], "--sut-xml", p["sut.xml"], "--no-report", "--quiet", "--out"]
    cmds = {"help": (["-m", "bayescal", "--help"], True, None),
            "fit": (fit + [out + "_fit"], True, out + "_fit"),
            "fit_nodiag": (fit + [out + "_nodiag", "--no-diagnose"], True, None),
            "floor": (["-c", FLOOR, p["sut.mseed"], p["ref.mseed"]], False, None)}
    if HUDDLE.is_dir():
        sys.path.insert(0, str(ROOT / "examples"))
        from real_huddle import write_inputs

        ref_xml, sut_xml = write_inputs(HUDDLE, os.path.join(folder, "huddle"))
        cmds["huddle"] = (["-m", "bayescal", "fit", "--ref", str(HUDDLE / "ref_STS2"),
                           "--ref-xml", ref_xml, "--sut", str(HUDDLE / "ref_unknown"),
                           "--sut-xml", sut_xml, "--fit-response", "gain", "--band", "0.1", "2",
                           "--no-report", "--quiet", "--out", out + "_huddle"], True,
                          out + "_huddle")
        cmds["obspy"] = (["-c", OBSPY, str(HUDDLE)], False, None)
    return cmds


def timed(argv, pythonpath, cwd):
    """(wall s, CPU s, peak memory MiB) of one subprocess; CPU = its user +
    system time, the steadier figure when other jobs share the cores; peak
    memory its ``ru_maxrss``. Run from ``cwd`` (not a source tree: ``python
    -m`` would import the package found there)."""
    env = dict(os.environ, PYTHONPATH=str(pythonpath), OMP_NUM_THREADS="1")
    t0 = time.perf_counter()
    child = subprocess.Popen([sys.executable] + argv, env=env, stdout=subprocess.DEVNULL,
                             cwd=cwd)
    _, status, usage = os.wait4(child.pid, 0)
    wall = time.perf_counter() - t0
    child.returncode = os.waitstatus_to_exitcode(status)
    if child.returncode not in (0, 3):          # 3: results written, a chain unconverged
        raise subprocess.CalledProcessError(child.returncode, argv)
    return wall, usage.ru_utime + usage.ru_stime, usage.ru_maxrss / 1024.0


def criticism_seconds(folder):
    """The criticism's seconds in ``folder``'s result.json, 0 when it did not run."""
    with open(os.path.join(folder, "result.json")) as fh:
        c = json.load(fh).get("criticism") or {}
    return float(c.get("seconds") or 0.0)


def _medians(times):
    return {k: statistics.median(v) for k, v in times.items() if v}


def _summary(kind, times, emcee_s):
    """Medians, ratios and goals of one kind of time (wall or CPU)."""
    med = _medians(times)
    ratios = {"fit / floor": med["fit"] / med["floor"],
              "fit_nodiag / floor": med["fit_nodiag"] / med["floor"]}
    if "huddle" in med:
        ratios["huddle / obspy"] = med["huddle"] / med["obspy"]
    for k in ("fit", "fit_nodiag", "huddle", "help"):
        if f"{k}_before" in med:
            ratios[f"{k}_before / {k}"] = med[f"{k}_before"] / med[k]
    med["import emcee (CPU)"] = emcee_s
    goals = {"fit_nodiag <= 1.5 x floor": ratios["fit_nodiag / floor"] <= 1.5,
             "help <= 0.3 s": med["help"] <= 0.3}
    if "huddle / obspy" in ratios:
        goals["huddle <= obspy (both with import emcee)"] = ratios["huddle / obspy"] <= 1.0
    print(f"--- {kind} time, medians (s)")
    for k, v in list(med.items()) + list(ratios.items()):
        print(f"{k:28s} {v:7.2f}")
    print("goals:", goals)
    return {"median_s": med, "ratios": ratios, "goals_met": goals}


def _repeat(runs, tmp, record):
    """One alternation of every command; appends to ``record``'s lists."""
    for name, argv_, path, folder in runs:
        w, c, mem = timed(argv_, path, tmp)
        crit = criticism_seconds(folder) if folder else 0.0
        for key, v in (("wall", w), ("cpu", c), ("peak_mib", mem), ("criticism_s", crit)):
            record[key].setdefault(name, []).append(v)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeats", type=int, default=7)
    ap.add_argument("--before", type=Path, help="another source tree to time in the same run")
    ap.add_argument("--out", default=str(ROOT / "reports" / "benchmarks" / "process.json"))
    ap.add_argument("--stages", action="store_true",
                    help="instead: CPU seconds by stage of the fit, the huddle and the floor")
    ap.add_argument("--prepare", metavar="DIR", help=argparse.SUPPRESS)
    a = ap.parse_args(argv)
    if a.prepare:                       # the child that writes the files
        with contextlib.redirect_stdout(sys.stderr):
            cmds = prepare(a.prepare)
        print(json.dumps(cmds))
        return 0
    command = "python benchmarks/bench_process.py " + " ".join(argv or sys.argv[1:])
    with tempfile.TemporaryDirectory() as tmp:
        # the files are written by a child: this process stays small, so
        # that no child's peak memory starts from a copy of it
        cmds = json.loads(subprocess.run([sys.executable, __file__, "--prepare", tmp],
                                         capture_output=True, text=True, check=True,
                                         env=dict(os.environ, PYTHONPATH=str(ROOT))).stdout)
        ours_path = installed(ROOT, os.path.join(tmp, "candidate"))
        if a.stages:
            load = os.getloadavg()
            medians, runs = stages(cmds, tmp, ours_path, a.repeats)
            return _write(os.path.join(os.path.dirname(a.out), "process_stages.json"),
                          {"command": command, "repeats": a.repeats,
                           "load_1_5_15_min": [load, os.getloadavg()],
                           "cpu_s_by_stage": medians, "runs": runs})
        runs = [(name, argv_, ours_path, folder) for name, (argv_, _, folder) in cmds.items()]
        if a.before:
            before = installed(a.before, os.path.join(tmp, "before"))
            runs += [(f"{name}_before", [x.replace(folder, folder + "_before") for x in argv_]
                      if folder else argv_, before, folder and folder + "_before")
                     for name, (argv_, ours, folder) in cmds.items() if ours]
        record, imports = _alternated(runs, tmp, ours_path, a.repeats)
    return _write(a.out, _result(command, a.repeats, record, imports))


def _alternated(runs, tmp, ours_path, repeats):
    """``repeats`` alternations of every command and of the emcee import's
    timing: ``(record, imports)``, each command's wall, CPU, peak memory
    and criticism seconds by repeat, the load, and the import's CPU."""
    record = {"wall": {}, "cpu": {}, "peak_mib": {}, "criticism_s": {}, "load": []}
    imports = []
    for r in range(repeats):
        record["load"].append(os.getloadavg())
        _repeat(runs, tmp, record)
        imports.append(float(subprocess.run(
            [sys.executable, "-c", IMPORT], env=dict(os.environ, PYTHONPATH=ours_path),
            capture_output=True, text=True, check=True, cwd=tmp).stdout.strip()))
        print(f"repeat {r + 1}/{repeats}, load {record['load'][-1][0]:.1f} (wall/CPU s): "
              + ", ".join(f"{k} {record['wall'][k][-1]:.2f}/{record['cpu'][k][-1]:.2f}"
                          for k in record["wall"]), flush=True)
    return record, imports


def _result(command, repeats, record, imports):
    """The stored result of a run: every repeat's figures, their medians,
    ratios and goals (printed as well)."""
    result = {"command": command, "machine": f"{os.cpu_count()} cores, shared",
              "repeats": repeats, "load_1_5_15_min": record["load"],
              "runs_wall_s": record["wall"], "runs_cpu_s": record["cpu"],
              "runs_peak_mib": record["peak_mib"], "criticism_s": record["criticism_s"],
              "import_emcee_cpu_s": imports}
    emcee_s = statistics.median(imports)
    for kind in ("wall", "cpu"):
        result[kind] = _summary(kind, record[kind], emcee_s)
    result["peak_mib"] = _medians(record["peak_mib"])
    result["criticism_median_s"] = _medians(record["criticism_s"])
    result["goals_met"] = {f"{k} peak memory <= 226 MiB": result["peak_mib"][k] <= 226.0
                           for k in ("fit_nodiag", "fit")}
    print("peak memory, MiB (median):", {k: round(v) for k, v in result["peak_mib"].items()})
    print("criticism, s (median, from result.json; 0: it did not run):",
          {k: round(v, 2) for k, v in result["criticism_median_s"].items()})
    print("load average over the run (1 min):", [round(x[0], 1) for x in record["load"]])
    print("goals:", result["goals_met"])
    return result


def _write(path, result):
    os.makedirs(os.path.dirname(path), exist_ok=True)
    with open(path, "w") as fh:
        json.dump(result, fh, indent=1)
    return 0


if __name__ == "__main__":
    sys.exit(main())
