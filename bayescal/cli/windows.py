"""Cut a pair's record into consecutive windows, fit each, and combine them
into the record's value.

Each window of --window seconds (default 600) in [--start, --end) is fitted
as `bayescal fit` fits one (the same options; the criticism only with
--diagnose). Per parameter (each SUT channel's azimuth, dip where estimated,
relative gain where fitted) the windows' medians and standard deviations are
combined by a model of the record: the record's value plus a slow wander
between windows (an Ornstein-Uhlenbeck process of unknown size and time
scale, which no single window can measure) plus each window's own error.

Each window is fitted with the Gaussian likelihood (each band's noise as
estimated, no per-band heavy tail; --window-likelihood gaussian, the
default). A window's noise inflation (the scatter of its segments: about a
dozen in a ten-minute window) is floored at the record's: the median over
the windows of the most common bands, per band; a window whose own falls
below it is fitted again with it. One factor on all the windows' standard
deviations is learned over the record beside the wander (its prior
log-uniform on [1, 4]: the record widens a window's interval, never
narrows it). --window-likelihood per-band fits each
window with bayescal fit's likelihood (a heavy-tailed noise scale per band),
without the floor, the factor 1.
Written into DIR:

  windows.csv    one row per window and parameter: start, end, median, its
                 95 % interval, and the window's 95 % interval for the
                 record's value (its posterior widened by the wander)
  record.json    per parameter: the record's value (median, 68 and 95 %),
                 the wander's size and time scale, the factor on the
                 windows' sds (scale), the repeatability ratios
                 without and with the wander; the windows skipped and why;
                 "settings": what reproduces the run: band_hz (--band, null
                 when each window's band is chosen), bands_used_hz (the
                 windows' bands), seed (window k fitted with seed + k),
                 window_s, window_likelihood, start and end (ISO: the span
                 cut into windows, as --start and --end), windows_fitted,
                 windows_skipped, fit_response, diagnose, keep_transients,
                 max_steps; "inflation_floor": the record's noise inflation per
                 band (per_band), its bands' edges, the windows fitted
                 again with it and those of other bands (not_pooled)
  windows.pdf    each parameter's windows against time, the record's value
  windows.png    and its band, the wander's smoothed path (unless --no-report)

A window the fit refuses (too little gap-free data, no coherence in the
band) is skipped and named with its reason; a parameter is combined from
at least three fitted windows that estimate it (a value held in a window
has no interval and is left out of that parameter's record). An azimuth
is written as bayescal fit writes one: its median in [0, 360), its
intervals contiguous about it (one across north may end below 0 or above
360); in windows.csv each window's about its own median. A fit stage that
its work budget ended in some windows is said once after the table, with
how many times (as bayescal fit says it below its summary).
docs/windows.md explains the model and its assumptions.

Example:
  bayescal windows --ref REF.mseed --ref-xml REF.xml --sut SUT.mseed --sut-xml SUT.xml \\
                   --out record --band 0.125 0.333 --window 600

Exit codes: 0 success; 2 bad input (one line naming the file and the
problem; nothing is written to DIR); 3 results written, but the sampler of
some window stopped at --max-steps before meeting its convergence rule (a
NOT CONVERGED line names each; record.json lists them under
"not_converged").
"""
from __future__ import annotations

import csv
import os
import sys
import warnings

from ..errors import BudgetWarning, InputWarning
from .common import add_pair_arguments, priors_from, quiet_convergence_warnings, say, staging

HELP = "fit consecutive windows of a record and combine them into the record's value"
#: --window-likelihood: each window's fit keywords, and whether the record learns the sds' factor.
WINDOW_LIKELIHOODS = {"gaussian": ({"misfit_shape": float("inf"), "pool_inflation": True}, True),
                      "per-band": ({}, False)}


def configure(parser):
    """Arguments of ``bayescal windows``."""
    add_pair_arguments(parser)
    parser.add_argument("--window", type=float, default=600.0, metavar="SECONDS",
                        help="length of each window in seconds (default 600)")
    parser.add_argument("--window-likelihood", choices=list(WINDOW_LIKELIHOODS),
                        default="gaussian",
                        help="each window's likelihood: gaussian (the default: each band's noise "
                             "as estimated, its inflation floored at the record's, one factor "
                             "on the windows' sds learned over the record) or per-band "
                             "(bayescal fit's, a heavy-tailed noise scale per band)")
    parser.add_argument("--diagnose", action="store_true",
                        help="criticise each window whose model check fails, as bayescal fit "
                             "does (by default the windows are not criticised)")


def fit_all(args, pair):
    """Every window's fit, with a progress line per window on stderr, and
    the budget notes (:func:`said_once`)."""
    from ..record import fit_windows

    kept, seen = {}, [0]          # each window's warnings: those of the fit kept

    def said(k, n, w):
        if w.fitted or not w.floored:         # a refit that fails leaves the first fit
            kept[k] = caught[seen[0]:]
        seen[0] = len(caught)
        what = ("fitted again with the record's noise inflation as a floor" if w.floored
                and w.fitted else f"not fitted again with the record's noise inflation "
                f"({w.reason}); its first fit kept" if w.floored
                else f"skipped: {w.reason}" if not w.fitted else "fitted")
        say(args, f"window {k + 1}/{n} {str(w.start)[:19]} - {str(w.end)[:19]}: {what}")

    ref, ref_xml, sut, sut_xml = pair
    with warnings.catch_warnings(record=True) as caught, quiet_convergence_warnings():
        warnings.simplefilter("always", InputWarning)
        warnings.simplefilter("always", BudgetWarning)
        windows = fit_windows(ref=ref, ref_xml=ref_xml, sut=sut, sut_xml=sut_xml, start=args.start,
                              end=args.end, window=args.window, seed=args.seed, on_window=said,
                              band=tuple(args.band) if args.band else None,
                              fit_response=args.fit_response, priors=priors_from(args),
                              ref_noise=args.ref_noise, ref_noise_psd=args.ref_noise_psd,
                              transients="keep" if args.keep_transients else "drop",
                              max_steps=args.max_steps, diagnose=args.diagnose,
                              **WINDOW_LIKELIHOODS[args.window_likelihood][0])
    return windows, said_once([m for k in sorted(kept) for m in kept[k]] + caught[seen[0]:])


def said_once(caught):
    """Each distinct input or budget warning among ``caught`` once, with how
    many times the windows gave it: the input warnings printed as
    ``bayescal: warning:`` lines on stderr, the budget notes returned, to be
    printed with the table on stdout (as ``bayescal fit`` says both:
    :func:`~bayescal.cli.fit.said_warnings`)."""
    from .fit import said_warnings
    counts = {}
    for w in caught:
        if issubclass(w.category, (InputWarning, BudgetWarning)):
            key = (str(w.message), w.category)
            counts[key] = counts.get(key, 0) + 1
    return said_warnings([warnings.WarningMessage(message + (f" ({n} times)" if n > 1 else ""),
                                                  category, "", 0)
                          for (message, category), n in counts.items()])


def write_csv(records, path):
    """windows.csv: one row per window and parameter."""
    with open(path, "w", newline="") as fh:
        out = csv.writer(fh)
        out.writerow(["start", "end", "parameter", "median", "ci95_low", "ci95_high",
                      "record_ci95_low", "record_ci95_high"])
        for name, rec in records.items():
            for start, end, median, ci95, record in rec.rows():
                out.writerow([str(start)[:19], str(end)[:19], name, f"{median:.6g}",
                              f"{ci95[0]:.6g}", f"{ci95[1]:.6g}", f"{record[0]:.6g}",
                              f"{record[1]:.6g}"])


def run_settings(windows, args):
    """record.json's ``settings``: what reproduces the run (with the same
    files and the span's ``start`` and ``end`` as --start and --end)."""
    used = []
    for w in windows:
        if w.band_hz is not None and w.band_hz not in used:
            used.append(w.band_hz)
    fitted = sum(w.fitted for w in windows)
    return {"band_hz": list(args.band) if args.band else None, "bands_used_hz": used,
            "seed": args.seed, "window_s": args.window,
            "window_likelihood": args.window_likelihood,
            "start": windows[0].start.isoformat(), "end": windows[-1].end.isoformat(),
            "windows_fitted": fitted, "windows_skipped": len(windows) - fitted,
            "fit_response": args.fit_response, "diagnose": args.diagnose,
            "keep_transients": args.keep_transients, "max_steps": args.max_steps}


def record_document(records, windows, args):
    """record.json's content."""
    from ..version import __version__
    return {"schema": "bayescal.windows/1", "version": __version__, "window_s": args.window,
            "window_likelihood": args.window_likelihood,
            "settings": run_settings(windows, args),
            "windows": len(windows), "fitted": sum(w.fitted for w in windows),
            "skipped": [{"start": str(w.start)[:19], "end": str(w.end)[:19], "reason": w.reason}
                        for w in windows if not w.fitted],
            "not_converged": [str(w.start)[:19] for w in windows
                              if w.fitted and not w.convergence.get("converged", True)],
            "inflation_floor": inflation_floor(windows),
            "parameters": {name: rec.summary() for name, rec in records.items()}}


def inflation_floor(windows):
    """record.json's ``inflation_floor``: the record's noise inflation per
    band (:mod:`bayescal.record.pooling`; null when the windows were not
    pooled), the bands' edges (Hz), the windows fitted again with it and
    the fitted windows of other bands, which no floor reached
    (``not_pooled``)."""
    pooled = [w for w in windows if w.floor is not None]
    return {"per_band": [float(c) for c in pooled[0].floor] if pooled else None,
            "band_edges_hz": list(pooled[0].band_edges_hz) if pooled else None,
            "windows": [str(w.start)[:19] for w in windows if w.floored],
            "not_pooled": [str(w.start)[:19] for w in windows
                           if pooled and w.fitted and w.floor is None]}


def table_rows(records):
    """The table's rows: parameter, record value [95 %], wander sd [95 %],
    time scale (h), repeatability ratio without / with the wander (and the
    factor on the windows' sds [95 %], when it is learned)."""
    learned = any(rec.fit.scale_grid.size > 1 for rec in records.values())
    rows = [("parameter", "record value [95%]", "wander sd [95%]", "scale h",
             "ratio without / with") + (("sd factor [95%]",) if learned else ())]
    for name, rec in records.items():
        mu, tau, lam = rec.fit.mu, rec.fit.tau, rec.fit.scale
        rows.append((name, f"{mu['median']:.5g} [{mu['ci95'][0]:.5g}, {mu['ci95'][1]:.5g}]",
                     f"{tau['median']:.2g} [{tau['ci95'][0]:.2g}, {tau['ci95'][1]:.2g}]",
                     f"{rec.fit.ell['median'] / 3600:.2g}",
                     f"{rec.fit.ratio_without:.2f} / {rec.fit.ratio_with:.2f}")
                    + ((f"{lam['median']:.2f} [{lam['ci95'][0]:.2f}, {lam['ci95'][1]:.2f}]",)
                       if learned else ()))
    return rows


def print_table(records, stream=None):
    """The record's value, the wander and the ratios, one line per parameter."""
    rows = table_rows(records)
    widths = [max(len(r[k]) for r in rows) for k in range(len(rows[0]))]
    for r in rows:
        print("  ".join(c.ljust(w) for c, w in zip(r, widths)).rstrip(), file=stream or sys.stdout)


def run(args):
    """Fit the windows, combine them, write DIR; returns the exit code."""
    from ..atomic import write_json
    from ..errors import InputError
    from ..record import combine
    from ..record.wander import MIN_WINDOWS

    out = os.path.abspath(args.out)
    if os.path.exists(out) and not os.path.isdir(out):
        raise InputError(f"{args.out}: exists and is not a folder")
    if not args.window > 0:
        raise InputError(f"--window {args.window:g}: a window is a positive number of seconds")
    say(args, "bayescal windows: reading recordings and metadata ...")
    from ..pair.workflow import read_pair
    windows, spent = fit_all(args, read_pair(ref=args.ref, ref_xml=args.ref_xml, sut=args.sut,
                                             sut_xml=args.sut_xml, sut_id=args.sut_id,
                                             ref_id=args.ref_id))
    fitted = sum(w.fitted for w in windows)
    if fitted < MIN_WINDOWS:
        reasons = "; ".join(sorted({w.reason for w in windows if not w.fitted}))
        raise InputError(f"{fitted} of {len(windows)} windows fitted: the record's value needs "
                         f"at least {MIN_WINDOWS}" + (f" ({reasons})" if reasons else ""))
    records = combine(windows, seed=args.seed,
                      learn_scale=WINDOW_LIKELIHOODS[args.window_likelihood][1])
    with staging(out) as tmp:
        write_csv(records, os.path.join(tmp, "windows.csv"))
        write_json(os.path.join(tmp, "record.json"), record_document(records, windows, args))
        if not args.no_report:
            from ..record import write_figure
            write_figure(records, tmp)
    print_table(records)
    for w in windows:
        if not w.fitted:
            print(f"skipped {str(w.start)[:19]}: {w.reason}")
    for line in spent:       # a stage its budget ended: said with the table, as bayescal fit does
        print(line)
    from .common import convergence_exit, written
    code = convergence_exit([(f"the sampler of window {str(w.start)[:19]}", w.convergence)
                             for w in windows if w.fitted])
    say(args, f"wrote {out} ({', '.join(written(out))})")
    return code
