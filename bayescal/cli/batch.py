"""Calibrate many SUT/reference pairs on Dask, resumably.

PLAN is either
  a CSV file with the columns label,ref,ref_xml,sut,sut_xml (paths relative
  to the CSV's folder; several waveform files separated by ';') and optional
  band_min,band_max,fit_response,seed,start,end per row; or
  sds:ARCHIVE, an SDS archive (YEAR/NET/STA/CHAN.D/NET.STA.LOC.CHAN.D.YEAR.DOY)
  with --inventory (a StationXML file or folder): at every station, location
  --sut-location (10) against --ref-location (00), one item per day.

Each item's result goes to DIR/<label>/ (written atomically); a failed item
writes DIR/<label>/error.json and the others go on. Rerunning the same
command skips finished items and retries failed ones. At the end:
DIR/results.csv (a row per item and channel), DIR/flags.csv and the summary
report DIR/report.pdf / report.png (orientation against time per station;
a result is flagged when off nominal, or changed from the same pair's
result before, by more than --threshold and beyond the 95 % uncertainty;
two pairs of one station, e.g. two references, are never compared).

Exit status: 0 when every item is calibrated, 1 when some failed (their
errors are in results.csv), 2 for bad input (plan, paths, options).

Examples:
  bayescal batch --plan pairs.csv --out runs/ --workers 2
  bayescal batch --plan sds:/data/sds --inventory /data/xml --days 2026-01-01 2026-01-31 \\
      --out runs/ --scheduler tcp://scheduler:8786
"""
from __future__ import annotations

from ..errors import InputError
from ..report.flags import FLAG_THRESHOLD_DEG, FLAG_THRESHOLD_PCT
from .common import add_paper_argument

HELP = "calibrate many pairs (CSV plan or SDS archive) on Dask, resumable, with a network report"


def configure(parser):
    parser.add_argument("--plan", required=True, metavar="PLAN",
                        help="CSV plan file, or sds:ARCHIVE_DIR for the SDS rule")
    parser.add_argument("--out", required=True, metavar="DIR", help="output folder")
    parser.add_argument("--inventory", metavar="XML_OR_DIR",
                        help="StationXML file or folder (needed with sds:)")
    parser.add_argument("--days", nargs=2, metavar=("FIRST", "LAST"),
                        help="with sds: only these days (inclusive, YYYY-MM-DD)")
    parser.add_argument("--sut-location", default="10", help="SUT location code (sds:, default 10)")
    parser.add_argument("--ref-location", default="00",
                        help="reference location code (sds:, default 00)")
    parser.add_argument("--band", nargs=2, type=float, metavar=("FMIN", "FMAX"),
                        help="band in Hz for items whose plan row gives none (default: chosen "
                             "per pair from the data where the sensors are coherent)")
    parser.add_argument("--fit-response", choices=("none", "gain", "all"), default="gain",
                        help="default response fit (default gain: angles and each channel's "
                             "gain; none: gains held at their metadata values)")
    parser.add_argument("--scheduler", metavar="ADDRESS",
                        help="address of a running Dask scheduler (default: a local cluster)")
    parser.add_argument("--workers", type=int, metavar="N",
                        help="local workers (default: one per core)")
    parser.add_argument("--seed", type=int, default=0,
                        help="global seed; each item's seed derives from it and its label")
    parser.add_argument("--threshold", type=float, default=FLAG_THRESHOLD_DEG, metavar="DEG",
                        help="flag azimuth and dip offsets / changes above this and beyond "
                             f"the 95 %% interval (default {FLAG_THRESHOLD_DEG:g} degrees, as "
                             "bayescal report)")
    parser.add_argument("--gain-threshold", type=float, default=FLAG_THRESHOLD_PCT, metavar="PCT",
                        help="flag gain offsets / changes above this and beyond the 95 %% "
                             f"interval (default {FLAG_THRESHOLD_PCT:g} %%)")
    parser.add_argument("--quiet", action="store_true", help="no progress bar")
    add_paper_argument(parser)


def make_plan(args):
    """Plan items from the command-line arguments."""
    from ..network.plan import default_options, read_csv_plan, sds_plan

    if args.band and not 0 < args.band[0] < args.band[1]:
        raise InputError(f"--band {args.band[0]} {args.band[1]}: need 0 < FMIN < FMAX")
    defaults = default_options(band=args.band, fit_response=args.fit_response)
    if args.plan.startswith("sds:"):
        if not args.inventory:
            raise InputError(f"{args.plan}: an SDS plan needs --inventory XML_OR_DIR")
        return sds_plan(args.plan[4:], args.inventory, sut_location=args.sut_location,
                        ref_location=args.ref_location, days=args.days, defaults=defaults)
    if args.days or args.inventory:
        raise InputError(f"{args.plan}: --days and --inventory apply to sds: plans only")
    return read_csv_plan(args.plan, defaults)


def run(args):
    from ..network.batch import run_batch

    items = make_plan(args)
    if args.workers is not None and args.workers < 1:
        raise InputError("--workers must be at least 1")
    s = run_batch(items, args.out, seed=args.seed, scheduler=args.scheduler,
                  workers=args.workers, quiet=args.quiet, threshold_deg=args.threshold,
                  gain_threshold_pct=args.gain_threshold, paper=args.paper)
    flagged = sorted({f["station"] for f in s["flag_list"]})
    print(f"{len(items)} items: {s['computed']} calibrated, {s['skipped']} already done, "
          f"{s['failed']} failed; flagged stations: {', '.join(flagged) or 'none'}")
    print(f"results: {s['results']}  report: {s['pdf']}")
    return 1 if s["failed"] else 0
