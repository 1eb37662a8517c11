"""Calibrate a sensor under test (SUT) against a co-located reference.

Reads both sensors' recordings (any format ObsPy reads; several files per
side) and StationXML, estimates the SUT's channel orientations and gains
(relative gain = fitted / metadata; --fit-response none holds the gains,
--fit-response all also fits period and damping), and writes into DIR:

  result.json        medians, 68/90/95 % credible intervals, convergence,
                     the band and the amount of data used
  samples.npz        posterior samples
  diagnostics.npz    spectra, coherence and misfit per band (for reports)
  sut_corrected.xml  the SUT's StationXML with azimuth, dip (and fitted
                     response values) replaced by posterior medians, with
                     plusError/minusError from the 68 % interval
  report.pdf         figures of the fit (unless --no-report)

When the model check fails, the fit looks for the cause (unless
--no-diagnose): it names what the model leaves out, models it, shows the
misfit before and after and how far each estimate moves, and ends with a
verdict: the estimates are usable as they are, or the improved model's
head the result (the table, result.json, the report and sut_corrected.xml
give them; the fit's are kept as "rejected_fit"), or the misfit stays
unexplained (where, and what to try). result.json keeps it under
"criticism".

Only segments in which every channel is continuous are used; the band used,
how it was chosen and the amount of data used are printed and kept in
result.json. Channels the reference cannot see (a SUT vertical beside a
horizontal-only reference) are listed as not estimable.

Example:
  bayescal fit --ref REF.mseed --ref-xml REF.xml --sut SUT.mseed --sut-xml SUT.xml \\
               --out result --band 0.05 1 --start 2024-01-01T00:00:00 --end 2024-01-01T06:00:00

Sensors without StationXML that are flat (velocity) in the band: give
--ref-xml flat / --sut-xml flat (orientation from the channel code: N or 1 =
north, E or 2 = east, Z = vertical).

Exit codes: 0 success; 2 bad input (one line naming the file and the problem;
nothing is written to DIR); 3 results written, but the sampler stopped at
--max-steps before meeting its convergence rule (a NOT CONVERGED line says so;
the intervals are provisional).
"""
from __future__ import annotations

import os
import sys
import time
import warnings

from .common import (add_pair_arguments, add_report_pages_arguments, convergence_exit, priors_from,
                     quiet_convergence_warnings, say, staging)

HELP = "estimate the SUT's orientation and gain (and response) from recordings beside a reference"


def configure(parser):
    """Arguments of ``bayescal fit``."""
    add_pair_arguments(parser)
    add_report_pages_arguments(parser)
    parser.add_argument("--no-diagnose", action="store_true",
                        help="when the model check fails, do not look for the cause (by "
                             "default the fit then names what the model leaves out, models it "
                             "and says whether the estimates can be used; docs/diagnose.md)")
    from ..criticism.verdict import DEFAULT_BUDGET_S, WORK_PER_SECOND
    parser.add_argument("--diagnose-budget", type=float, default=DEFAULT_BUDGET_S,
                        metavar="SECONDS",
                        help="work spent looking for the cause of a misfit, in seconds of "
                             f"{WORK_PER_SECOND} model evaluations each, about a second on a "
                             f"two-core computer (default {DEFAULT_BUDGET_S:g}; counted in work, so "
                             "the same seed names the same effects on any machine; checked "
                             "between candidate effects: when "
                             "it runs out the output says which were tried and the misfit "
                             "stays unexplained; ten times as many seconds of wall clock stop "
                             "it as a safety net, and the output then says so)")


def _fmt(entry):
    """An entry's median with its 95 % interval, "(fixed)" without one, or
    "-" when it has no value (an angle the data leave undefined)."""
    if entry.get("median") is None:
        return "- (" + entry.get("note", "undefined").split(":")[0] + ")"
    if "ci95" in entry:
        lo, hi = entry["ci95"]
        modes = " MULTIMODAL: see modes" if entry.get("multimodal") else ""
        return f"{entry['median']:.3f} [{lo:.3f}, {hi:.3f}]{modes}"
    return f"{entry['median']:.3f} (fixed)"


def _tilt_text(tilt):
    """A near-vertical channel's tilt at 95 %: an upper bound when the
    credible region of its lean holds the vertical, else an interval."""
    lo, hi = tilt["ci95"]
    if tilt.get("holds_zero", False):
        return f"tilt < {hi:.3f} deg, 95 % (vertical within it)"
    return f"tilt {tilt['median']:.3f} [{lo:.3f}, {hi:.3f}] deg, 95 %"


def pinned_gains(summary):
    """SUT channels whose fitted gain sits at a bound of its prior."""
    return [cid for cid, e in summary["channels"].items()
            if "pinned" in str((e.get("response") or {}).get("gain", {}).get("reason", ""))]


def response_lines(entry, fmt=_fmt):
    """A channel's response lines: measured values with 95 % intervals
    (``fmt(entry) -> text``); a value the prior sets is named as such, never
    printed as a measurement, and then the combination the data fix
    (damping / period) is given. Shared by ``bayescal cal`` and ``uvw``."""
    resp = entry.get("response", {})
    nominal = entry.get("nominal") or {}
    units = {"period_s": " s", "gain": f" {nominal.get('gain_units', '')}".rstrip(),
             "relative_gain": " (fitted / metadata gain)"}
    out = []
    for name, r in resp.items():
        if name == "damping_over_period":
            continue
        if r.get("set_by_prior") and r.get("action", "").startswith("held"):
            out.append(f"{name} {fmt(r)}{units.get(name, '')}  held at its nominal value: "
                       "the data do not constrain it")
        elif r.get("set_by_prior") and name in ("period_s", "damping"):
            nom = nominal.get(name)
            nom_text = f" (nominal {nom:.6g}{units.get(name, '')})" if nom is not None else ""
            out.append(f"{name}: set by the prior, not measured{nom_text}")
        elif r.get("set_by_prior"):
            out.append(f"{name} {fmt(r)}{units.get(name, '')}  SET BY THE PRIOR: {r['reason']}")
        else:
            out.append(f"{name} {fmt(r)}{units.get(name, '')}")
    combo = resp.get("damping_over_period")
    prior_set = [n for n in ("period_s", "damping") if resp.get(n, {}).get("set_by_prior")]
    if combo and prior_set:
        if combo.get("set_by_prior"):
            out.append("damping/period: also set by the prior; the data fix neither")
        else:
            lo, hi = combo["ci95"]
            words = " and ".join({"period_s": "period"}.get(n, n) for n in prior_set)
            out.append(f"the data fix damping/period = {combo['median']:.4g} [{lo:.4g}, "
                       f"{hi:.4g}] 1/s; {words} separately set by the prior")
    return out


def print_summary(summary, stream=None):
    """A short table of the result: the model check first (a fit that fails
    it says so before any number), under which model the estimates are when
    it is the criticism's improved model, then medians and 95 % intervals."""
    from ..core.posterior import multimodal_line

    stream = stream or sys.stdout       # looked up now, not at import (redirection works)
    crit = summary.get("criticism") or {}
    _print_check(summary, stream)
    modes = multimodal_line(summary)
    if modes:
        print(modes, file=stream)
    meta = summary.get("meta", {})
    if meta.get("band_hz"):   # with the results on stdout: `> out.txt` keeps it
        lo, hi = meta["band_hz"]
        print(f"band used: {lo:.4g} - {hi:.4g} Hz ({meta.get('band_choice', '')})", file=stream)
    print("channel                 azimuth deg [95%]           dip deg [95%]", file=stream)
    for cid, e in summary["channels"].items():
        az = e["azimuth_deg"]
        vertical = abs(e["dip_deg"]["median"]) > 89.999 and "ci95" not in az
        az_text = "- (vertical)" if vertical or az.get("undefined") else _fmt(az)
        print(f"{cid:22s}  {az_text:28s}  {_fmt(e['dip_deg'])}", file=stream)
        if "ci95" in e.get("tilt_deg", {}):
            print(f"{'':22s}  {_tilt_text(e['tilt_deg'])}", file=stream)
        for line in response_lines(e):
            print(f"{'':22s}  {line}", file=stream)
    for pair, e in summary.get("orthogonality_deg", {}).items():
        print(f"{'angle ' + pair:46s}  {_fmt(e)}{' (assumed)' if e.get('assumed') else ''}",
              file=stream)
    if summary.get("meta", {}).get("assumption"):
        print(f"assumed: {summary['meta']['assumption']}", file=stream)
    for cid, why in summary.get("not_estimable", {}).items():
        print(f"{cid:22s}  not estimable: {why}", file=stream)
    _print_notes(summary, stream)
    if crit:
        print_criticism(crit, stream)


def _print_notes(summary, stream):
    """The lines below the table: the reference's noise, the record, the
    sensor order, pinned gains, whose self-noise, and the convergence (or
    the Laplace approximation that stands for a chain)."""
    from ..criticism.words import posterior_text, self_noise_text
    from ..result import Convergence

    rn = summary.get("meta", {}).get("reference_noise", {})
    if rn:
        from ..core.posterior import describe_treatment
        print(f"reference noise: {describe_treatment(rn)}", file=stream)
    if rn.get("input", {}).get("extrapolated"):
        print(f"reference noise: {rn['input']['extrapolated']}", file=stream)
    note = rn.get("separation", {}).get("note")
    if note:
        print(f"reference noise: {note}", file=stream)
    if rn.get("gain_bounds", {}).get("note"):
        print(f"reference noise: {rn['gain_bounds']['note']}", file=stream)
    short = summary.get("meta", {}).get("record_length", {}).get("note")
    if short:
        print(f"record: {short}", file=stream)
    order = summary.get("sensor_order", {})
    if order.get("message"):
        print(f"WARNING: {order['message']}", file=stream)
    elif order.get("caution"):
        print(f"sensor order: {order['caution']}", file=stream)
    if self_noise_text(summary) and (summary.get("self_noise") or order):
        print(self_noise_text(summary), file=stream)
    pinned = pinned_gains(summary)
    if pinned and not order.get("message"):
        print(f"WARNING: the gain of {', '.join(pinned)} is pinned at the bound of its prior: "
              "the data want a gain further from the metadata than the prior allows. Check the "
              "metadata gain, and whether --ref and --sut are swapped", file=stream)
    clock = (summary.get("response_curve") or {}).get("time_correction")
    if clock:
        print(f"time correction: {clock['text']}", file=stream)
    c = summary["convergence"]
    laplace = posterior_text(summary)
    print(f"convergence: {laplace}" if laplace else f"convergence: {Convergence.figures(c)}, "
          f"autocorrelation time up to {c['tau_max']:.1f} steps, {c['n_steps']} steps", file=stream)


def _print_check(summary, stream):
    """The fit's own model check (the rejected fit's when the criticism's
    improved model heads the result), then under which model the estimates
    are when it is the improved model."""
    from ..core.checks import describe
    from ..criticism.words import headline

    crit = summary.get("criticism") or {}
    check = (summary.get("rejected_fit") or {}).get("adequacy") or summary.get("adequacy")
    if check:
        print(describe(check, next_step=crit.get("verdict_text") and
                       "What it means: see the verdict below the table."), file=stream)
    if headline(summary):
        print(headline(summary), file=stream)


def print_criticism(crit, stream=None):
    """The criticism of a fit that failed its model check: what was found,
    how the misfit and the estimates moved, what to do, and the verdict
    last."""
    from ..criticism.verdict import lines

    stream = stream or sys.stdout
    text = lines(crit)
    print(f"criticism ({crit.get('seconds', 0):.1f} s; docs/diagnose.md):", file=stream)
    for line in text[1:] + text[:1]:
        print(line, file=stream)


def transient_words(transients):
    """The console's clause on the segments a transient left out ('' if none)."""
    if not transients:
        return ""
    ratio = transients["ratio"]
    return (f"; {transients['dropped']} left out for a transient in one sensor (incoherent power "
            f"{min(ratio):.3g}-{max(ratio):.3g} times that of the minutes around; "
            f"--keep-transients keeps them)")


def said_warnings(caught):
    """Print the input warnings among ``caught``; returns the budget notes
    (said with the summary, as the NOT CONVERGED line is)."""
    from ..errors import BudgetWarning, InputWarning

    for w in caught:
        if issubclass(w.category, InputWarning):
            print(f"bayescal: warning: {w.message}", file=sys.stderr)
    return [str(w.message) for w in caught if issubclass(w.category, BudgetWarning)]


def run(args):
    """Run the fit; returns the exit code."""
    from ..core import progress
    from ..errors import BudgetWarning, InputError, InputWarning
    from ..io.result import write_results
    from ..pair.workflow import calibrate_files

    out = os.path.abspath(args.out)
    if os.path.exists(out) and not os.path.isdir(out):
        raise InputError(f"{args.out}: exists and is not a folder")
    t_start = time.perf_counter()
    with warnings.catch_warnings(record=True) as caught, quiet_convergence_warnings(), \
            progress.shown(not args.quiet):
        warnings.simplefilter("always", InputWarning)
        warnings.simplefilter("always", BudgetWarning)
        say(args, "bayescal fit: reading recordings and metadata ...")
        post = calibrate_files(ref=args.ref, ref_xml=args.ref_xml, sut=args.sut,
                               sut_xml=args.sut_xml,
                               band=tuple(args.band) if args.band else None,
                               fit_response=args.fit_response, seed=args.seed,
                               start=args.start, end=args.end, progress=not args.quiet,
                               sut_id=args.sut_id, ref_id=args.ref_id, ref_noise=args.ref_noise,
                               ref_noise_psd=args.ref_noise_psd, max_steps=args.max_steps,
                               transients="keep" if args.keep_transients else "drop",
                               priors=priors_from(args),
                               diagnose=not args.no_diagnose,
                               diagnose_budget_s=args.diagnose_budget)
    spent = said_warnings(caught)
    meta = post.meta
    used = meta.data_used
    say(args, f"data used: {used['segments']} of {used['segments_possible']} segments "
               f"({100 * used['fraction']:.0f} %, about {used['approx_seconds']:.0f} s)"
               + transient_words(used.get("transients")))
    if meta.reference_tolerance is not None:
        say(args, f"reference metadata: gain, period and damping known to "
                  f"{100 * meta.reference_tolerance['relative_sd']:g} % (1 sd); the SUT's "
                  f"response intervals carry it")
    with staging(out) as tmp:
        write_results(post, tmp)
        if not args.no_report:
            from ..report.fit import write_report
            say(args, "writing the report ...")
            try:
                write_report(tmp, paper=args.paper, png=args.png, full=args.full)
            except Exception as exc:  # the fit's results matter more than its figures
                print(f"bayescal: warning: the report could not be written "
                      f"({type(exc).__name__}: {exc}); results are complete", file=sys.stderr)
    elapsed = time.perf_counter() - t_start
    summary = post.summary()
    print_summary(summary)   # --quiet removes the progress display only
    for line in spent:       # a stage's budget ended it: said as the NOT CONVERGED line is
        print(line)
    code = convergence_exit([("the sampler", summary["convergence"])])
    from .common import written
    say(args, f"wrote {out} ({', '.join(written(out))}) in {elapsed:.1f} s")
    return code
