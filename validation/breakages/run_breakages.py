"""Apply each deliberate breakage of the package to a scratch copy of the
repository and check that the tests meant to catch it fail.

Every entry of ``breakages.json`` names a patch in ``patches/`` (a unified
diff against the package) and the pytest node ids that must catch it. The
script:

1. copies the repository into a temporary directory (by default the
   committed tree, ``git archive HEAD``; ``--worktree`` copies the working
   tree's tracked and untracked, not ignored, files instead);
2. runs every listed test once on the unbroken copy (all must pass, or a
   failure under a breakage would prove nothing);
3. for each breakage: applies its patch (``git apply``; with one line of
   context if the package has moved on around the changed line), runs its
   tests, records each test's outcome and, when none of them fails, runs
   the rest of the suite with ``-x`` (``--no-rest`` skips that) and records
   the first test that fails there; then reverts the patch;
4. writes ``results.json`` and ``results.md`` beside this script: for each
   breakage, caught (at least one of its tests failed) or not, and by which.

Usage (from anywhere; takes about ten minutes on two cores)::

    python validation/breakages/run_breakages.py [--worktree] [--only NAME ...]
                                                 [--workers N] [--keep] [--no-rest]

It exits with code 1 if a breakage is not caught, or if a listed test fails
on the unbroken copy. A breakage caught only by the rest of the suite
counts as caught, and the table says by which test: its entry in
``breakages.json`` should then name that test.
"""
from __future__ import annotations

import argparse
import datetime
import json
import os
import shutil
import subprocess
import sys
import tempfile
import time
import xml.etree.ElementTree as ET
from pathlib import Path

HERE = Path(__file__).resolve().parent
REPO = HERE.parents[1]


def _git(*args, cwd=REPO, **kw):
    return subprocess.run(["git", *args], cwd=cwd, check=True, capture_output=True, text=True,
                          **kw).stdout


def copy_repository(dest, worktree):
    """The committed tree (or the working tree) of the repository in ``dest``."""
    if worktree:
        files = _git("ls-files", "-z", "--cached", "--others", "--exclude-standard").split("\0")
        for rel in filter(None, files):
            src = REPO / rel
            if src.is_file():
                (dest / rel).parent.mkdir(parents=True, exist_ok=True)
                shutil.copy2(src, dest / rel)
    else:
        archive = subprocess.run(["git", "archive", "--format=tar", "HEAD"], cwd=REPO,
                                 check=True, capture_output=True).stdout
        subprocess.run(["tar", "-x", "-C", str(dest)], input=archive, check=True)
    # a git repository of its own, so that patches apply and revert cleanly
    for args in (["init", "-q"], ["add", "-A"],
                 ["-c", "user.name=breakages", "-c", "user.email=breakages@localhost",
                  "commit", "-q", "-m", "scratch copy"]):
        _git(*args, cwd=dest)


def run_tests(copy, node_ids, workers, report, rest=False):
    """Run ``node_ids`` in ``copy``; returns {node id: outcome} from pytest's
    JUnit XML report (passed, failed, error, skipped, or not run). With
    ``rest``, run the whole suite but ``node_ids`` instead, stopping at the
    first failure (``-x``), and return the outcomes of the tests that failed
    there."""
    files = {n.split("::")[0] for n in node_ids}
    cmd = [sys.executable, "-m", "pytest", "-q", "-p", "no:cacheprovider", "--junitxml",
           str(report)]
    if rest:
        cmd += ["-x", "tests", *(f"--deselect={n}" for n in node_ids)]
        files = {"tests"} | {str(p.relative_to(copy)) for p in (copy / "tests").glob("test_*.py")}
    else:
        cmd += list(node_ids)
    if workers > 1 and len(files) > 1:
        cmd += ["-n", str(min(workers, len(files))), "--dist", "loadfile"]
    env = dict(os.environ, PYTHONPATH=str(copy), PYTHONDONTWRITEBYTECODE="1")
    t0 = time.perf_counter()
    proc = subprocess.run(cmd, cwd=copy, env=env, capture_output=True, text=True)
    seconds = time.perf_counter() - t0
    outcomes = {} if rest else {n: "not run" for n in node_ids}
    if report.exists():
        for case in ET.parse(report).getroot().iter("testcase"):
            module = case.get("classname", "").replace(".", "/") + ".py"
            name = case.get("name", "")
            node = f"{module}::{name}"
            base = f"{module}::{name.split('[')[0]}"
            kind = "passed"
            for child in case:
                if child.tag in ("failure", "error"):
                    kind = "failed" if child.tag == "failure" else "error"
                elif child.tag == "skipped" and kind == "passed":
                    kind = "skipped"
            key = node if node in outcomes else base
            if rest and kind in ("failed", "error"):
                outcomes[node] = kind
            elif key in outcomes:
                # a parametrised test fails if any of its cases fails
                prev = outcomes[key]
                order = ["not run", "skipped", "passed", "error", "failed"]
                outcomes[key] = max(prev, kind, key=order.index) if prev != "not run" else kind
        report.unlink()
    return outcomes, seconds, proc


def check_import(copy):
    """The copy's package is the one imported there (not the editable install)."""
    env = dict(os.environ, PYTHONPATH=str(copy))
    out = subprocess.run([sys.executable, "-c", "import bayescal; print(bayescal.__file__)"],
                         cwd=copy, env=env, capture_output=True, text=True, check=True).stdout
    path = Path(out.strip()).resolve()
    if copy.resolve() not in path.parents:
        raise SystemExit(f"the scratch copy imports bayescal from {path}, not from {copy}")


def markdown(result):
    lines = ["# Deliberate breakages and the tests that catch them", "",
             f"Produced by `python validation/breakages/run_breakages.py` on {result['date']} "
             f"({result['source']}, {result['seconds']:.0f} s in all). Each breakage is one patch "
             "in `patches/`, applied alone to a scratch copy of the repository; a breakage is "
             "caught when at least one of its tests fails. Every listed test passed on the "
             "unbroken copy first"
             + ("." if result["baseline_ok"] else " -- EXCEPT the ones marked in results.json."),
             "", "| breakage | what it breaks | caught | failing tests | passing tests | s |",
             "|---|---|---|---|---|---|"]
    for b in result["breakages"]:
        failed = ([n.split("::")[-1] for n, o in b["outcomes"].items()
                   if o in ("failed", "error")]
                  + [f"{n.split('::')[-1]} (rest of the suite)"
                     for n in b.get("caught_by_rest", [])])
        passed = [n.split("::")[-1] for n, o in b["outcomes"].items()
                  if o not in ("failed", "error")]
        caught = "yes" if b["caught"] else ("PATCH DID NOT APPLY" if b.get("apply_error")
                                            else "NO")
        lines.append(f"| `{b['name']}` | {b['what']} | {caught} | "
                     f"{'<br>'.join(failed) or '-'} | {'<br>'.join(passed) or '-'} | "
                     f"{b['seconds']:.0f} |")
    n = len(result["breakages"])
    k = sum(b["caught"] for b in result["breakages"])
    lines += ["", f"{k} of {n} breakages caught.", ""]
    return "\n".join(lines)


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--worktree", action="store_true",
                        help="copy the working tree instead of the committed tree (HEAD)")
    parser.add_argument("--only", nargs="+", metavar="NAME", help="run these breakages only")
    parser.add_argument("--workers", type=int, default=2, help="pytest-xdist workers (2)")
    parser.add_argument("--keep", action="store_true", help="keep the scratch copy")
    parser.add_argument("--no-rest", action="store_true",
                        help="do not run the rest of the suite when a breakage's own tests "
                             "all pass")
    parser.add_argument("--out", default=str(HERE), help="folder for results.json/.md")
    args = parser.parse_args(argv)

    spec = json.loads((HERE / "breakages.json").read_text())
    if args.only:
        spec = [b for b in spec if b["name"] in args.only]
    t_start = time.perf_counter()
    scratch = Path(tempfile.mkdtemp(prefix="bayescal-breakages-"))
    copy = scratch / "repo"
    copy.mkdir()
    try:
        copy_repository(copy, args.worktree)
        check_import(copy)
        commit = _git("rev-parse", "HEAD").strip()
        source = (f"working tree on {commit[:10]}" if args.worktree
                  else f"committed tree {commit[:10]}")
        report = scratch / "report.xml"
        every = sorted({n for b in spec for n in b["tests"]})
        print(f"unbroken copy: {len(every)} tests ...", flush=True)
        baseline, secs, proc = run_tests(copy, every, args.workers, report)
        bad = {n: o for n, o in baseline.items() if o != "passed"}
        print(f"  {len(every) - len(bad)} passed in {secs:.0f} s"
              + (f"; NOT PASSING: {bad}" if bad else ""), flush=True)
        if bad:
            print(proc.stdout[-3000:])
        results = []
        for b in spec:
            patch = HERE / "patches" / f"{b['name']}.patch"
            entry = {"name": b["name"], "what": b["what"], "patch": f"patches/{patch.name}",
                     "tests": b["tests"]}
            context = []
            try:
                _git("apply", str(patch), cwd=copy)
            except subprocess.CalledProcessError:
                # the package moved on around the changed line: one line of context
                try:
                    context = ["-C1"]
                    _git("apply", *context, str(patch), cwd=copy)
                    entry["applied_with"] = "one line of context (-C1)"
                except subprocess.CalledProcessError as exc:
                    entry.update(caught=False, apply_error=exc.stderr.strip(), outcomes={},
                                 seconds=0.0)
                    results.append(entry)
                    print(f"{b['name']}: the patch does not apply: {exc.stderr.strip()}",
                          flush=True)
                    continue
            try:
                outcomes, secs, _ = run_tests(copy, b["tests"], args.workers, report)
                caught = any(o in ("failed", "error") for o in outcomes.values())
                if not caught and not args.no_rest:
                    print(f"{b['name']}: not caught by its tests; the rest of the suite ...",
                          flush=True)
                    rest, rest_secs, _ = run_tests(copy, b["tests"], args.workers, report,
                                                   rest=True)
                    entry["caught_by_rest"] = sorted(rest)
                    secs += rest_secs
            finally:
                _git("apply", "-R", *context, str(patch), cwd=copy)
            if entry.get("caught_by_rest"):
                # a test of the rest counts only if it passes on the unbroken copy
                check, _, _ = run_tests(copy, entry["caught_by_rest"], args.workers, report)
                entry["caught_by_rest"] = [n for n, o in check.items() if o == "passed"]
            caught = (any(o in ("failed", "error") for o in outcomes.values())
                      or bool(entry.get("caught_by_rest")))
            entry.update(caught=caught, outcomes=outcomes, seconds=round(secs, 1))
            results.append(entry)
            failing = ([n for n, o in outcomes.items() if o in ("failed", "error")]
                       + [f"{n} (rest of the suite)" for n in entry.get("caught_by_rest", [])])
            print(f"{b['name']}: {'caught by ' + ', '.join(failing) if caught else 'NOT CAUGHT'}"
                  f" ({secs:.0f} s)", flush=True)
        result = {"date": datetime.date.today().isoformat(), "source": source,
                  "commit": commit, "python": sys.version.split()[0],
                  "seconds": round(time.perf_counter() - t_start, 1),
                  "baseline": baseline, "baseline_ok": not bad, "breakages": results,
                  "caught": sum(r["caught"] for r in results), "total": len(results)}
        out = Path(args.out)
        (out / "results.json").write_text(json.dumps(result, indent=1) + "\n")
        (out / "results.md").write_text(markdown(result))
        print(f"{result['caught']} of {result['total']} caught; wrote {out / 'results.md'}")
        return 0 if (not bad and result["caught"] == result["total"]) else 1
    finally:
        if args.keep:
            print(f"scratch copy kept in {copy}")
        else:
            shutil.rmtree(scratch, ignore_errors=True)


if __name__ == "__main__":
    sys.exit(main())
