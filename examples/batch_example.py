"""Batch calibration of a simulated network, end to end.

Writes a small SDS archive (3 stations x 3 days, 1 h a day at 10 Hz; station
ST02's SUT is turned by 5 degrees from the second day on, its StationXML is
not), calibrates every station-day on a local Dask cluster (the same as
``bayescal batch --plan sds:ARCHIVE --inventory XML_DIR --out DIR``), and
copies the network's tables and report into ``--out``:

    results.csv   one row per station-day and SUT channel
    flags.csv     flags per pair (a SUT channel against its reference channels):
                  off nominal, or changed between days
    report.pdf    summary page + orientation against time per station
    report.png    the first orientation page
    truth.json    what the simulation put in

The archive and the per-pair result folders (posterior samples, a few MB)
stay in ``--work`` (a temporary folder unless given).

    python examples/batch_example.py --out reports/batch
"""
from __future__ import annotations

import argparse
import os
import shutil
import tempfile


def main():
    from bayescal.network.batch import run_batch
    from bayescal.simulate.network import write_network
    from bayescal.network.plan import default_options, sds_plan
    from bayescal.report.batch import FLAG_THRESHOLD_DEG

    ap = argparse.ArgumentParser(description=" ".join(__doc__.split("\n\n")[0].split()))
    ap.add_argument("--out", default="reports/batch")
    ap.add_argument("--work", help="folder for the archive and the per-pair results")
    ap.add_argument("--workers", type=int, help="Dask workers (default: one per core)")
    ap.add_argument("--threshold", type=float, default=FLAG_THRESHOLD_DEG,
                    help=f"flag threshold, degrees (default {FLAG_THRESHOLD_DEG:g}, as bayescal batch)")
    args = ap.parse_args()

    work = args.work or tempfile.mkdtemp(prefix="bayescal_batch_")
    net = write_network(os.path.join(work, "network"), n_stations=3, n_days=3, seed=11,
                        rotated_station="ST02", rotation_deg=5.0)
    print(f"archive {net['archive']}: stations {', '.join(net['stations'])}, days "
          f"{', '.join(net['days'])}; truth: {net['rotation']['station']} turned by "
          f"{net['rotation']['degrees']} deg from {net['rotation']['from_day']}")
    items = sds_plan(net["archive"], net["inventory"],
                     defaults=default_options(fit_response="gain"))
    runs = os.path.join(work, "runs")
    s = run_batch(items, runs, seed=1, workers=args.workers, threshold_deg=args.threshold)
    print(f"{s['computed']} calibrated, {s['skipped']} already done, {s['failed']} failed")
    for f in s["flag_list"]:
        when = f"{f['previous_day']} -> {f['day']}" if f["flag"] == "changed" else f["day"]
        print(f"  flagged {f['channel']} (against {f['reference_channels']}) {f['quantity']} "
              f"{f['flag']} {when}: "
              f"{f['value']:+.2f} {f['unit']} [{f['lo95']:+.2f}, {f['hi95']:+.2f}]")
    os.makedirs(args.out, exist_ok=True)
    for name in ("results.csv", "flags.csv", "report.pdf", "report.png"):
        shutil.copy(os.path.join(runs, name), os.path.join(args.out, name))
    shutil.copy(net["truth"], os.path.join(args.out, "truth.json"))
    print(f"report: {os.path.join(args.out, 'report.pdf')}")
    if not args.work:
        shutil.rmtree(work, ignore_errors=True)


if __name__ == "__main__":
    main()
