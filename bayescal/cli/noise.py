"""Self-noise of three or more co-located sensors (Sleeman et al. 2006).

Reads one recording and one metadata entry per sensor (same order; sampling
rates may differ; one to three channels per sensor), removes the responses,
and for every component (Z, N, E) recorded by three or more sensors estimates
each sensor's self-noise with a 90 % interval. The metadata are what
`bayescal fit` takes: StationXML, a RESP file, a GSE2 poles-and-zeros file, or
'flat' (a flat velocity response of 1 count per m/s, orientation from the
channel code; that sensor's numbers are then not in ground units).

Prints each sensor's self-noise averaged over a few period bands, in dB re
1 (m/s^2)^2/Hz with its 90 % interval; where the interval reaches zero power
the self-noise is below what the data resolve, and the line gives the upper
bound only ("< X below resolution"). Writes into DIR:

  noise.json   {"schema": "bayescal.noise/1", "sensors": {SEED id: {"period_s",
               "psd_db", "ci90_db": [lower, upper], "below_resolution",
               "period_bands", ...}}, "meta": {...}};
               PSD in dB re 1 (m/s^2)^2/Hz, null where not estimable
  noise_curves.npz  the estimates at full precision, from which the figures
               are drawn (`bayescal report DIR` redraws them)
  noise.pdf    one A4 page per component, against Peterson's NLNM and NHNM
               (below resolution: a downward marker at the upper bound)
  noise_Z.png  (and _N, _E) the same pages as PNG

With more than three sensors each sensor's estimate is the median over all
pairs of the others. Horizontal sensors must be aligned with each other. The
interval allows by default for 1 mrad rms differences between the sensors'
sensitive axes (--axis-mismatch; see docs/noise.md).

Example:
  bayescal noise --data A.mseed B.mseed C.mseed --xml A.xml B.xml C.xml --out DIR
  bayescal noise --data A.mseed B.mseed C.mseed --xml A.xml B.resp flat --out DIR

Exit codes: 0 success, 2 bad input (one line naming the file and the problem;
nothing is written to DIR).
"""
from __future__ import annotations

import os
import sys
import time
import warnings

from .common import parse_time, say, staging

HELP = "self-noise of three or more co-located sensors, with 90-percent intervals"


def configure(parser):
    """Arguments of ``bayescal noise``."""
    parser.add_argument("--data", nargs="+", required=True, metavar="FILE",
                        help="one recording per sensor (miniSEED or any format ObsPy reads)")
    parser.add_argument("--xml", nargs="+", required=True, metavar="XML",
                        help="one metadata entry per sensor, in the same order as --data: "
                             "StationXML, a RESP file, a GSE2 .cal poles-and-zeros file, or "
                             "'flat' (flat velocity response, orientation from the channel "
                             "code)")
    parser.add_argument("--out", required=True, metavar="DIR", help="output folder")
    parser.add_argument("--band", nargs=2, type=float, metavar=("FMIN", "FMAX"),
                        help="frequency band in Hz (default: periods up to 100 s or a 40th "
                             "of the record, up to 0.8 of Nyquist)")
    parser.add_argument("--start", type=parse_time, metavar="T",
                        help="start of the analysis window")
    parser.add_argument("--end", type=parse_time, metavar="T", help="end of the analysis window")
    parser.add_argument("--interval", choices=["wishart", "block"], default="wishart",
                        help="interval: parametric complex-Wishart bootstrap (default) or block "
                             "bootstrap over time segments (under-covers; see docs)")
    parser.add_argument("--axis-mismatch", type=float, default=None, metavar="RAD",
                        help="allowance for differences between the sensors' sensitive axes, "
                             "rad rms per sensor and direction (default 1e-3; 0 = sampling "
                             "error only)")
    parser.add_argument("--n-boot", type=int, default=1000, help="bootstrap replicates "
                                                                 "(default 1000)")
    parser.add_argument("--seed", type=int, default=0, help="random seed (default 0)")
    parser.add_argument("--no-report", action="store_true", help="no PDF/PNG figures")
    parser.add_argument("--quiet", action="store_true", help="no progress messages")


def _check_options(args):
    from ..errors import InputError

    if args.n_boot < 20:
        raise InputError(f"--n-boot {args.n_boot}: give at least 20 replicates")
    am = args.axis_mismatch
    if am is not None and not (am >= 0 and am < 0.1):
        raise InputError(f"--axis-mismatch {am}: give a value in radians in [0, 0.1)")
    if args.band and not (0 < args.band[0] < args.band[1]):
        raise InputError(f"--band {args.band[0]} {args.band[1]}: not a positive interval")
    out = os.path.abspath(args.out)
    if os.path.exists(out) and not os.path.isdir(out):
        raise InputError(f"{args.out}: exists and is not a folder")
    return out


def run(args):
    """Estimate, write noise.json (and the figures) atomically; returns the exit code."""
    from ..io.noise import AXIS_MISMATCH, self_noise_files, to_json, write_json
    from ..errors import InputWarning

    out = _check_options(args)
    t_start = time.perf_counter()
    kw = dict(band=tuple(args.band) if args.band else None, start=args.start, end=args.end,
              method=args.interval, n_boot=args.n_boot, seed=args.seed,
              axis_mismatch=AXIS_MISMATCH if args.axis_mismatch is None else args.axis_mismatch,
              progress=None if args.quiet else (lambda m: say(args, m)))
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always", InputWarning)
        say(args, "bayescal noise: reading recordings and metadata ...")
        result = self_noise_files(args.data, args.xml, **kw)
    for w in caught:
        if issubclass(w.category, InputWarning):
            print(f"bayescal: warning: {w.message}", file=sys.stderr)
    with staging(out) as tmp:
        from ..report.noise import save_curves, write_report_from_folder

        write_json(result, tmp)
        save_curves(result, tmp)
        if not args.no_report:
            say(args, "drawing the figures ...")
            try:
                write_report_from_folder(tmp)
            except Exception as exc:  # the numbers matter more than the figures
                print(f"bayescal: warning: the figures could not be drawn "
                      f"({type(exc).__name__}: {exc}); noise.json is complete", file=sys.stderr)
    for line in summary_lines(to_json(result)):
        print(line)
    from .common import written
    say(args, f"wrote {out} ({', '.join(written(out))}) in "
              f"{time.perf_counter() - t_start:.1f} s")
    return 0


#: The console's unit of a self-noise in ground units, and of one whose
#: response was given as ``flat`` (1 count per m/s: counts as velocity).
GROUND_UNIT = "dB re 1 (m/s^2)^2/Hz"
FLAT_UNIT = "dB re 1 (count/s)^2/Hz"


def _cell(band, key):
    lo, hi = band[key]
    if hi is None:
        return "not estimable"
    if band["below_resolution"]:
        return f"< {hi:.1f} below resolution"
    psd = "(<= 0)" if band["psd_db"] is None else f"{band['psd_db']:.1f}"
    return f"{psd} [{lo:.1f}, {hi:.1f}]"


def summary_lines(doc):
    """The console table of a ``bayescal.noise/1`` document: per component,
    one row per period band, one column per sensor."""
    sensors = doc["sensors"]
    level = round(100 * doc["meta"].get("level", 0.9))
    key = f"ci{level}_db"
    flat = [c for c in doc["meta"].get("flat_metadata") or [] if c in sensors]
    unit = FLAT_UNIT if flat and len(flat) == len(sensors) else GROUND_UNIT
    lines = [f"self-noise, {unit}, mean over each period band [{level} % "
             f"interval]; '< X below resolution': the interval reaches zero power, X is its "
             f"upper bound"]
    by_comp = {}
    for cid, e in sensors.items():
        by_comp.setdefault(e["component"], []).append(cid)
    for comp, ids in by_comp.items():
        ranges = sorted({tuple(b["period_s"]) for cid in ids for b in sensors[cid]["period_bands"]})
        if not ranges:
            continue
        width = max([26] + [len(c) for c in ids])
        lines.append(f"component {comp}")
        lines.append(f"{'period s':>12}  " + "  ".join(f"{c:>{width}}" for c in ids))
        for r in ranges:
            cells = []
            for cid in ids:
                band = next((b for b in sensors[cid]["period_bands"]
                             if tuple(b["period_s"]) == r), None)
                cells.append("-" if band is None else _cell(band, key))
            lines.append(f"{f'{r[0]:.3g}-{r[1]:.3g}':>12}  "
                         + "  ".join(f"{c:>{width}}" for c in cells))
    if flat:
        lines.append(f"flat metadata: {', '.join(flat)}: "
                     + ("their columns are" if unit != FLAT_UNIT else "numbers")
                     + f" in {FLAT_UNIT}, the counts taken as velocity through an "
                     "assumed flat response of 1 count per m/s and differentiated, not in "
                     "ground units")
    return lines
