"""Rendering time of a calibration report for a saved result (the goal:
under 10 s).

Fits a simulated pair once (not timed), saves it, then renders the report
``--repeats`` times and prints the median wall-clock and CPU time per render
(CPU time is less sensitive to other jobs on a shared machine). With
``--response`` the fit includes period, damping and gain of every channel,
which adds the response corner page and 9 more trace panels (the heaviest
report). ``--folder DIR`` times an existing result folder instead.

    python benchmarks/bench_report.py [--repeats 5] [--response] [--folder DIR]
"""
from __future__ import annotations

import argparse
import json
import os
import statistics
import tempfile
import time


def make_result(folder, response):
    import bayescal
    from bayescal.io.result import save_posterior
    from bayescal.simulate.pair import simulate_pair

    sim = simulate_pair(duration=3600, fs=10, seed=5, coherence=0.99, sut_azimuth=(2, 91, 0),
                        sut_response=((28.0, 0.68, 780.0), (31.0, 0.72, 730.0),
                                      (30.0, 0.70, 760.0)))
    post = bayescal.calibrate(sut=sim.sut, sut_xml=sim.sut_inventory, ref=sim.ref, ref_xml=sim.ref_inventory,
                              band=(0.03, 1.0), fit_response="all" if response else "none",
                              progress=False)
    save_posterior(post, folder)
    return folder


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--repeats", type=int, default=5)
    p.add_argument("--response", action="store_true")
    p.add_argument("--folder", default=None)
    a = p.parse_args(argv)
    t0 = time.perf_counter()
    from bayescal.report.fit import write_report
    import_s = time.perf_counter() - t0
    with tempfile.TemporaryDirectory() as tmp:
        folder = a.folder or make_result(os.path.join(tmp, "result"), a.response)
        out = os.path.join(tmp, "report.pdf")
        wall, cpu = [], []
        for _ in range(a.repeats):
            w0, c0 = time.perf_counter(), time.process_time()
            paths = write_report(folder, out_pdf=out)
            wall.append(time.perf_counter() - w0)
            cpu.append(time.process_time() - c0)
        size = sum(os.path.getsize(q) for q in paths) / 1e6
        with open(os.path.join(folder, "result.json")) as fh:
            free = json.load(fh)["meta"].get("free_response", "none")
        print(f"result: {folder} (response fitted: {free})")
        print(f"pages/figures: {len(paths) - 1}, output {size:.2f} MB")
        print(f"import of bayescal.report: {import_s:.2f} s (once per process)")
        print(f"render, median of {a.repeats}: wall {statistics.median(wall):.2f} s "
              f"(min {min(wall):.2f}, max {max(wall):.2f}), CPU {statistics.median(cpu):.2f} s; "
              f"requirement < 10 s: {'met' if statistics.median(wall) < 10 else 'NOT met'}")
        print(f"load average at the end: {os.getloadavg()[0]:.1f} on {os.cpu_count()} cores")


if __name__ == "__main__":
    main()
