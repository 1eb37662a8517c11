"""Throughput of ``bayescal batch`` (pairs per minute) against Dask worker count.

A simulated SDS network (default 3 stations x 2 days, 1 h a day at 10 Hz) is
calibrated repeatedly by a ``distributed.LocalCluster`` of 1, 2, ... single-
threaded worker processes; each repetition starts from an empty output
folder. Reported per worker count: the median wall time of the batch on a
running cluster, pairs per minute from it, the speed-up against 1 worker
measured in the same run, the median cluster start-up time (paid once per
``bayescal batch`` call) and the median CPU seconds per pair (the worker
thread's CPU time), which bounds the throughput of an idle machine: a shared
machine's wall times depend on what else runs. It also checks that the posterior samples are
identical whatever the worker count (seeds derive from the labels).

    python benchmarks/bench_batch.py                 # workers 1 2, 3 repeats
    python benchmarks/bench_batch.py --workers 1 2 4 --repeats 5 --stations 4 --days 3
"""
from __future__ import annotations

import argparse
import logging
import os
import shutil
import statistics
import tempfile
import time

import numpy as np


def main():
    from distributed import LocalCluster

    from bayescal.network.batch import read_log, run_batch
    from bayescal.simulate.network import write_network
    from bayescal.network.plan import default_options, sds_plan

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--workers", type=int, nargs="+", default=[1, 2])
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--stations", type=int, default=3)
    ap.add_argument("--days", type=int, default=2)
    ap.add_argument("--band", type=float, nargs=2, default=(0.05, 1.0))
    args = ap.parse_args()

    work = tempfile.mkdtemp(prefix="bench_batch_")
    try:
        net = write_network(os.path.join(work, "net"), n_stations=args.stations,
                            n_days=args.days, seed=1)
        items = sds_plan(net["archive"], net["inventory"],
                         defaults=default_options(band=args.band))
        print(f"{len(items)} pairs ({args.stations} stations x {args.days} days, 1 h at 10 Hz "
              f"each), band {args.band[0]}-{args.band[1]} Hz, {os.cpu_count()} cores, "
              f"load average before: {os.getloadavg()[0]:.1f}")
        rows, samples = [], {}
        for n in args.workers:
            walls, starts, cpus = [], [], []
            for rep in range(args.repeats):
                t = time.perf_counter()
                cluster = LocalCluster(n_workers=n, threads_per_worker=1, processes=True,
                                       dashboard_address=None, silence_logs=logging.ERROR)
                starts.append(time.perf_counter() - t)
                out = os.path.join(work, f"out_{n}_{rep}")
                try:
                    t = time.perf_counter()
                    s = run_batch(items, out, seed=5, scheduler=cluster.scheduler_address,
                                  quiet=True, report=False)
                    walls.append(time.perf_counter() - t)
                finally:
                    cluster.close()
                assert s["computed"] == len(items), s
                cpus += [e["cpu_seconds"] for e in read_log(out) if e["event"] == "done"]
                samples[n] = {it["label"]: np.load(os.path.join(out, it["label"],
                                                                "samples.npz"))["samples"]
                              for it in items}
            wall = statistics.median(walls)
            rows.append((n, wall, 60 * len(items) / wall, statistics.median(starts),
                         min(walls), max(walls), statistics.median(cpus)))
        base = rows[0][1]
        print("\n| workers | median wall (s) | pairs / min | speed-up vs 1 | cluster start (s) "
              "| min-max wall (s) | median CPU s / pair |")
        print("|---|---|---|---|---|---|---|")
        for n, wall, ppm, start, lo, hi, cpu in rows:
            print(f"| {n} | {wall:.1f} | {ppm:.1f} | {base / wall:.2f} | {start:.1f} "
                  f"| {lo:.1f}-{hi:.1f} | {cpu:.1f} |")
        cpu = statistics.median(r[6] for r in rows)
        print(f"\nidle-machine bound from CPU time: {60 / cpu:.1f} pairs / min per core "
              f"({60 * os.cpu_count() / cpu:.1f} on {os.cpu_count()} cores)")
        first = samples[args.workers[0]]
        same = all(np.array_equal(first[k], samples[n][k]) for n in samples for k in first)
        print(f"\nposterior samples identical across worker counts: {same}")
        print(f"load average after: {os.getloadavg()[0]:.1f}")
    finally:
        shutil.rmtree(work, ignore_errors=True)


if __name__ == "__main__":
    main()
