"""A report against its fit: ``bayescal report`` and the ``bayescal fit
--no-report`` that made its folder, each a fresh process, alternated in one
run (the goal: the report takes at most its fit's time).

Two cases, simulated as the README simulates them (30 minutes at 10 Hz, band
0.03-1 Hz): ``pass``, a fit whose model check passes (``seed=3``, the SUT
turned 3 deg), and ``late``, one whose check fails, the SUT's clock 0.3 s
late (``seed=2``, ``timing_offset_s=0.3``), so the criticism runs in the fit
and its pages are in the report. Each repeat runs the fit, then the report
of the first fit's folder in each variant: ``report`` (the default: the PDF
without the pages drawn on request), ``full`` (``--full``: every page) and
``full_png`` (``--full --png``: every page, and each as a PNG). Printed:
medians of wall-clock and CPU seconds (the child's user + system time), the
ratio of each report to the fit, the machine's load (1-minute average,
waiting processes on its cores) before and after each case, and whether the
goal is met by the default report. ``--json`` keeps the runs.
``--baseline DIR`` (a source tree of bayescal, e.g. ``git archive`` of an
earlier commit unpacked there) adds that tree's ``bayescal report`` of the
same folder, alternated with the others, and the ratio default report /
baseline. ``--before DIR`` likewise adds another tree's report (e.g. the
commit before a change to the report: ``before_report``, and the ratios
default report / before, wall and CPU). Each tree's package runs from a
copy compiled to bytecode first,
as an installation is (``bench_process.installed``): no child spends its
start-up compiling bayescal's sources, whatever ``PYTHONDONTWRITEBYTECODE``
says.

    python benchmarks/bench_report.py [--repeats 5] [--cases pass late] [--json FILE]
                                      [--baseline DIR] [--before DIR]
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

from bench_process import installed

ROOT = Path(__file__).resolve().parents[1]

CASES = {"pass": {"seed": 3, "sut_azimuth": (3, 93, 0), "noise_in_counts": True},
         "late": {"seed": 2, "timing_offset_s": 0.3}}
#: The report's variants: name and the options of ``bayescal report``.
VARIANTS = {"report": [], "full": ["--full"], "full_png": ["--full", "--png"]}


def simulate(case, folder):
    """Write the recordings of ``case`` into ``folder``."""
    from bayescal import simulate_pair
    simulate_pair(duration=1800, fs=10, **CASES[case]).write(folder)


def timed(cmd, tree):
    """Run ``cmd`` (a fresh process in the compiled copy ``tree``, so that
    ``-m bayescal.cli`` runs that tree's code); returns (wall s, CPU s of
    the child)."""
    env = {**os.environ, "PYTHONPATH": os.path.abspath(tree)}
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    t0 = time.perf_counter()
    subprocess.run(cmd, check=True, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
                   cwd=tree, env=env)
    wall = time.perf_counter() - t0
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    return wall, (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)


def commands(data, out):
    """The fit of the recordings in ``data`` into ``out``, and its report."""
    cli = [sys.executable, "-m", "bayescal.cli"]
    fit = cli + ["fit", "--ref", f"{data}/ref.mseed", "--ref-xml", f"{data}/ref.xml",
                 "--sut", f"{data}/sut.mseed", "--sut-xml", f"{data}/sut.xml",
                 "--band", "0.03", "1", "--out", out, "--no-report", "--quiet"]
    return fit, cli + ["report", out]


def run_case(case, tmp, repeats, tree, others):
    """Alternate the fit and the report's variants of the compiled copy
    ``tree`` (and the report of each copy in ``others``, ``{"baseline":
    copy, "before": copy}`` or fewer) ``repeats`` times; returns the
    case's record."""
    data = os.path.join(tmp, case)
    simulate(case, data)
    load = os.getloadavg()[0]
    runs = {"fit": [], **{v: [] for v in VARIANTS}, **{f"{k}_report": [] for k in others}}
    for i in range(repeats):
        fit, _ = commands(data, os.path.join(tmp, f"{case}_fit{i}"))
        runs["fit"].append(timed(fit, tree))
        report = commands(data, os.path.join(tmp, f"{case}_fit0"))[1]
        for name, options in VARIANTS.items():
            runs[name].append(timed(report + options, tree))
        for name, other in others.items():
            runs[f"{name}_report"].append(timed(report, other))
    med = {k: {"wall_s": statistics.median(w for w, _ in v),
               "cpu_s": statistics.median(c for _, c in v)} for k, v in runs.items()}
    out = {"case": case, "repeats": repeats, "load_before": load, "runs": runs,
           "median": med, "load_after": os.getloadavg()[0],
           "ratio_wall": med["report"]["wall_s"] / med["fit"]["wall_s"],
           "ratio_cpu": med["report"]["cpu_s"] / med["fit"]["cpu_s"],
           "ratio_cpu_to_fit": {k: med[k]["cpu_s"] / med["fit"]["cpu_s"] for k in med}}
    if "baseline" in others:
        out["ratio_to_baseline_cpu"] = med["report"]["cpu_s"] / med["baseline_report"]["cpu_s"]
    if "before" in others:
        out["ratio_to_before"] = {k: med["report"][k] / med["before_report"][k]
                                  for k in ("wall_s", "cpu_s")}
    return out


def _print(r, repeats):
    """The lines of one case's record."""
    m = r["median"]
    print(f"{r['case']}: fit {m['fit']['wall_s']:.2f} s wall, {m['fit']['cpu_s']:.2f} s CPU; "
          f"report {m['report']['wall_s']:.2f} s wall, {m['report']['cpu_s']:.2f} s CPU; "
          f"report / fit {r['ratio_wall']:.2f} (wall), {r['ratio_cpu']:.2f} (CPU); "
          f"load {r['load_before']:.1f} -> {r['load_after']:.1f} on {os.cpu_count()} "
          f"cores; medians of {repeats}; goal (report <= its fit): "
          f"{'met' if r['ratio_wall'] <= 1 and r['ratio_cpu'] <= 1 else 'NOT met'}")
    for name in [*VARIANTS, "baseline_report", "before_report"][1:]:
        if name in m:
            print(f"  {name}: {m[name]['wall_s']:.2f} s wall, {m[name]['cpu_s']:.2f} s CPU, "
                  f"{r['ratio_cpu_to_fit'][name]:.2f} x the fit's CPU")
    if "ratio_to_before" in r:
        print(f"  report / before: {r['ratio_to_before']['wall_s']:.2f} (wall), "
              f"{r['ratio_to_before']['cpu_s']:.2f} (CPU)")


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--repeats", type=int, default=5)
    p.add_argument("--cases", nargs="+", choices=sorted(CASES), default=["pass", "late"])
    p.add_argument("--json", default="reports/benchmarks/report.json")
    p.add_argument("--baseline", metavar="DIR", help="source tree of the baseline's report")
    p.add_argument("--before", metavar="DIR", help="source tree of the report before a change")
    a = p.parse_args(argv)
    trees = {k: os.path.abspath(v) for k, v in (("baseline", a.baseline), ("before", a.before)) if v}
    out = []
    with tempfile.TemporaryDirectory() as tmp:
        tree = installed(ROOT, os.path.join(tmp, "candidate"))
        others = {k: installed(v, os.path.join(tmp, k)) for k, v in trees.items()}
        for case in a.cases:
            out.append(run_case(case, tmp, a.repeats, tree, others) | trees)
            _print(out[-1], a.repeats)
    if a.json:
        os.makedirs(os.path.dirname(os.path.abspath(a.json)), exist_ok=True)
        with open(a.json, "w") as fh:
            json.dump(out, fh, indent=1)


if __name__ == "__main__":
    main()
